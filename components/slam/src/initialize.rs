//! Initial estimates for a pose graph from its edges alone: chordal
//! relaxation (rotations by linear least squares on the chordal cost, then
//! projected onto SO(3); translations by linear least squares given the
//! rotations) and a breadth-first spanning tree of composed measurements.

use faer::linalg::solvers::SolveCore;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, MatMut, Side};
use nalgebra::{Matrix3, Vector3};

use crate::g2o::G2o;
use crate::lie::{project_so3, Pose};

/// Solve the SPD system given by upper-triangle triplets for `cols`
/// right-hand sides stored column after column in `rhs`.
fn solve_spd(
    n: usize,
    triplets: &[Triplet<usize, usize, f64>],
    rhs: &mut [f64],
    cols: usize,
) -> Result<(), String> {
    let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, triplets)
        .map_err(|e| format!("{e:?}"))?;
    let llt = a.sp_cholesky(Side::Upper).map_err(|e| format!("{e:?}"))?;
    llt.solve_in_place_with_conj(Conj::No, MatMut::from_column_major_slice_mut(rhs, n, cols));
    Ok(())
}

/// Index of vertex `v` among the unknowns when the anchor `a` is known.
fn unknown_index(v: usize, a: usize) -> Option<usize> {
    match v.cmp(&a) {
        std::cmp::Ordering::Less => Some(v),
        std::cmp::Ordering::Equal => None,
        std::cmp::Ordering::Greater => Some(v - 1),
    }
}

/// Index of the anchor vertex: the first fixed one, else the first.
pub fn anchor(g: &G2o) -> usize {
    g.fixed.iter().position(|f| *f).unwrap_or(0)
}

/// Chordal initialisation. The anchor keeps its pose.
pub fn chordal(g: &G2o) -> Result<Vec<Pose>, String> {
    let n = g.poses.len();
    let a = anchor(g);
    let idx = |v: usize| unknown_index(v, a);
    let m = n - 1;
    if m == 0 {
        return Ok(g.poses.clone());
    }
    // Rotation rows: each row r of R satisfies r_j = R_z^T r_i, weighted by kappa.
    let mut trip = Vec::new();
    let mut rhs = vec![0.0; 3 * m * 3];
    let ra = g.poses[a].r;
    for e in &g.edges {
        let (kappa, _) = g.sesync_weights(e);
        let mt = e.z.r.transpose();
        // residual = r_j - M r_i with M = R_z^T: H_ii += k M^T M = k I,
        // H_jj += k I, H_ij += -k M^T (rows i, cols j).
        for v in [e.i, e.j] {
            if let Some(p) = idx(v) {
                for d in 0..3 {
                    trip.push(Triplet::new(3 * p + d, 3 * p + d, kappa));
                }
            }
        }
        match (idx(e.i), idx(e.j)) {
            (Some(pi), Some(pj)) => {
                // Block (i, j) is -kappa M^T = -kappa R_z; only the upper
                // triangle is stored, so a block below goes in transposed.
                let b = -e.z.r * kappa;
                for r in 0..3 {
                    for c in 0..3 {
                        let (row, col, val) = (3 * pi + r, 3 * pj + c, b[(r, c)]);
                        if row <= col {
                            trip.push(Triplet::new(row, col, val));
                        } else {
                            trip.push(Triplet::new(col, row, val));
                        }
                    }
                }
            }
            (Some(pi), None) => {
                // r_j known (anchor row): gradient term M^T r_j for each row of R_a.
                for row in 0..3 {
                    let rj = ra.row(row).transpose();
                    let g = mt.transpose() * rj * kappa;
                    for d in 0..3 {
                        rhs[row * 3 * m + 3 * pi + d] += g[d];
                    }
                }
            }
            (None, Some(pj)) => {
                for row in 0..3 {
                    let ri = ra.row(row).transpose();
                    let g = mt * ri * kappa;
                    for d in 0..3 {
                        rhs[row * 3 * m + 3 * pj + d] += g[d];
                    }
                }
            }
            (None, None) => {}
        }
    }
    solve_spd(3 * m, &trip, &mut rhs, 3)?;
    let mut poses = g.poses.clone();
    for (v, pose) in poses.iter_mut().enumerate() {
        let Some(p) = idx(v) else { continue };
        let mut r = Matrix3::zeros();
        for row in 0..3 {
            for d in 0..3 {
                r[(row, d)] = rhs[row * 3 * m + 3 * p + d];
            }
        }
        pose.r = project_so3(&r);
    }
    translations(g, &mut poses, a)?;
    Ok(poses)
}

/// Translations by least squares given the rotations: t_j - t_i = R_i t_z,
/// weighted by tau; the anchor keeps its translation.
fn translations(g: &G2o, poses: &mut [Pose], a: usize) -> Result<(), String> {
    let n = poses.len();
    let m = n - 1;
    let idx = |v: usize| unknown_index(v, a);
    let mut trip = Vec::new();
    let mut rhs = vec![0.0; m * 3];
    let ta = poses[a].t;
    for e in &g.edges {
        let (_, tau) = g.sesync_weights(e);
        let d = poses[e.i].r * e.z.t;
        // residual t_j - t_i - d.
        if let Some(pi) = idx(e.i) {
            trip.push(Triplet::new(pi, pi, tau));
            for k in 0..3 {
                rhs[k * m + pi] -= tau * d[k];
            }
        }
        if let Some(pj) = idx(e.j) {
            trip.push(Triplet::new(pj, pj, tau));
            for k in 0..3 {
                rhs[k * m + pj] += tau * d[k];
            }
        }
        match (idx(e.i), idx(e.j)) {
            (Some(pi), Some(pj)) => trip.push(Triplet::new(pi.min(pj), pi.max(pj), -tau)),
            (Some(pi), None) => (0..3).for_each(|k| rhs[k * m + pi] += tau * ta[k]),
            (None, Some(pj)) => (0..3).for_each(|k| rhs[k * m + pj] += tau * ta[k]),
            (None, None) => {}
        }
    }
    solve_spd(m, &trip, &mut rhs, 3)?;
    for (v, pose) in poses.iter_mut().enumerate() {
        if let Some(p) = idx(v) {
            pose.t = Vector3::new(rhs[p], rhs[m + p], rhs[2 * m + p]);
        }
    }
    Ok(())
}

/// Compose measurements along a breadth-first spanning tree from the anchor.
/// Vertices the tree does not reach keep their file pose.
pub fn spanning_tree(g: &G2o) -> Vec<Pose> {
    let n = g.poses.len();
    let mut adj: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
    for (k, e) in g.edges.iter().enumerate() {
        adj[e.i].push((e.j, k));
        adj[e.j].push((e.i, k));
    }
    let mut poses = g.poses.clone();
    let mut seen = vec![false; n];
    let a = anchor(g);
    seen[a] = true;
    let mut queue = std::collections::VecDeque::from([a]);
    while let Some(v) = queue.pop_front() {
        for &(w, k) in &adj[v] {
            if seen[w] {
                continue;
            }
            seen[w] = true;
            let e = &g.edges[k];
            poses[w] = if e.i == v {
                poses[v].compose(&e.z)
            } else {
                poses[v].compose(&e.z.inverse())
            };
            queue.push_back(w);
        }
    }
    poses
}
