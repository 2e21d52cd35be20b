//! Per-point covariances from the k nearest neighbours, regularised the
//! GICP way (Segal, Haehnel, Thrun 2009): the eigenvalues of the sample
//! covariance are replaced by (1, 1, eps), so every point becomes a small
//! plane patch whose normal is the eigenvector of the smallest eigenvalue.
//!
//! With those eigenvalues the covariance is `I - (1 - eps) n n^T`, so only
//! the smallest eigenvector is needed; it is computed in closed form (the
//! trigonometric eigenvalue formula, then a cross product of two rows of
//! `A - lambda I`), which is several times faster than an iterative solver
//! and allocates nothing.

use nalgebra::{Matrix3, Vector3};

use super::kdtree::{KdTree, Neighbor, MAX_K};

/// Neighbours per covariance (GICP's and small_gicp's default).
pub const DEFAULT_NEIGHBORS: usize = 10;
/// Eigenvalue given to the normal direction (the other two are 1).
pub const PLANE_EPSILON: f64 = 1e-3;

/// `I - (1 - eps) n n^T` for a unit normal `n`: eigenvalues (1, 1, eps).
pub fn plane_covariance(n: &Vector3<f64>, eps: f64) -> Matrix3<f64> {
    Matrix3::identity() - (1.0 - eps) * n * n.transpose()
}

/// Regularised covariance of every point of `tree`, in tree order, into
/// `out` (cleared first). `k` neighbours (the point itself included, at
/// most [`MAX_K`]); a point with fewer than 3 neighbours (a cloud of 1 or 2
/// points) gets the identity. Allocates only if `out` has less capacity
/// than the tree has points.
pub fn estimate(tree: &KdTree, k: usize, eps: f64, out: &mut Vec<Matrix3<f64>>) {
    out.clear();
    estimate_next(tree, k, eps, out, usize::MAX);
}

/// Continue [`estimate`] in bounded parts: the covariances of the next (at
/// most) `max_points` points after the `out.len()` already computed.
/// Returns true when every point has its covariance. The parts together
/// give the same values as one call.
pub fn estimate_next(
    tree: &KdTree,
    k: usize,
    eps: f64,
    out: &mut Vec<Matrix3<f64>>,
    max_points: usize,
) -> bool {
    let mut nn = [Neighbor {
        index: 0,
        dist_sq: 0.0,
    }; MAX_K];
    let nn = &mut nn[..k.clamp(1, MAX_K)];
    let pts = tree.points();
    let start = out.len().min(pts.len());
    let end = start.saturating_add(max_points).min(pts.len());
    let mut prev_found = 0;
    for p in &pts[start..end] {
        // Why seed the search radius: the previous point (its tree
        // neighbour, usually close) has k distinct neighbours, so the k-th
        // nearest of `p` is no farther than the farthest of them. That
        // bound prunes the search from its first node, and since those
        // points are within it the result is still the exact k nearest.
        let mut bound = f64::INFINITY;
        if prev_found == nn.len() {
            bound = 0.0;
            for n in nn.iter() {
                bound = f64::max(bound, dist_sq(&pts[n.index as usize], p));
            }
        }
        let mut found = tree.knn(p, bound, nn);
        if found < nn.len() && bound.is_finite() {
            // Not expected (the seeds are inside the bound); stay exact.
            found = tree.knn(p, f64::INFINITY, nn);
        }
        prev_found = found;
        if found < 3 {
            out.push(Matrix3::identity());
            continue;
        }
        // Centred on the query point first: keeps the sums small far from
        // the origin.
        let mut mean = Vector3::zeros();
        for n in &nn[..found] {
            let q = &pts[n.index as usize];
            mean += Vector3::new(q[0] - p[0], q[1] - p[1], q[2] - p[2]);
        }
        mean /= found as f64;
        let mut c = Matrix3::zeros();
        for n in &nn[..found] {
            let q = &pts[n.index as usize];
            let d = Vector3::new(q[0] - p[0], q[1] - p[1], q[2] - p[2]) - mean;
            c += d * d.transpose();
        }
        out.push(plane_covariance(&smallest_eigenvector(&c), eps));
    }
    end == pts.len()
}

#[inline(always)]
fn dist_sq(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let (x, y, z) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    x * x + y * y + z * z
}

/// Unit eigenvector of the smallest eigenvalue of the symmetric matrix `a`.
/// When that eigenvalue is repeated any unit vector of its eigenspace is
/// returned (deterministically); a zero or non-finite matrix gives +z.
pub fn smallest_eigenvector(a: &Matrix3<f64>) -> Vector3<f64> {
    let scale = a.amax();
    if !(scale > 0.0 && scale.is_finite()) {
        return Vector3::z();
    }
    // Scaled to entries in [-1, 1]: the formulas below neither overflow nor
    // underflow.
    let b = a / scale;
    let q = b.trace() / 3.0;
    let d = b - Matrix3::from_diagonal_element(q);
    let off = b[(0, 1)] * b[(0, 1)] + b[(0, 2)] * b[(0, 2)] + b[(1, 2)] * b[(1, 2)];
    let p2 = d[(0, 0)] * d[(0, 0)] + d[(1, 1)] * d[(1, 1)] + d[(2, 2)] * d[(2, 2)] + 2.0 * off;
    if p2 <= 0.0 {
        // A multiple of the identity: every vector is an eigenvector.
        return Vector3::z();
    }
    let p = (p2 / 6.0).sqrt();
    let r = ((d / p).determinant() / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let smallest = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    let m = b - Matrix3::from_diagonal_element(smallest);
    let rows = [
        Vector3::new(m[(0, 0)], m[(0, 1)], m[(0, 2)]),
        Vector3::new(m[(1, 0)], m[(1, 1)], m[(1, 2)]),
        Vector3::new(m[(2, 0)], m[(2, 1)], m[(2, 2)]),
    ];
    // The eigenvector is orthogonal to every row of A - lambda I: the
    // largest cross product of two rows is the best-conditioned estimate.
    let cands = [
        rows[0].cross(&rows[1]),
        rows[0].cross(&rows[2]),
        rows[1].cross(&rows[2]),
    ];
    let mut best = cands[0];
    for c in &cands[1..] {
        if c.norm_squared() > best.norm_squared() {
            best = *c;
        }
    }
    let n2 = best.norm_squared();
    if n2 > 1e-24 {
        return best / n2.sqrt();
    }
    // Rank <= 1: the smallest eigenvalue is repeated; any vector orthogonal
    // to the remaining row direction will do.
    let mut row = rows[0];
    for r in &rows[1..] {
        if r.norm_squared() > row.norm_squared() {
            row = *r;
        }
    }
    if row.norm_squared() <= 1e-24 {
        return Vector3::z();
    }
    // Cross with the axis least aligned with the row.
    let axis = row.iamin();
    let mut e = Vector3::zeros();
    e[axis] = 1.0;
    row.cross(&e).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, SymmetricEigen};

    fn check(a: Matrix3<f64>) {
        let v = smallest_eigenvector(&a);
        let e = SymmetricEigen::new(a);
        let lmin = e.eigenvalues.min();
        assert!((v.norm() - 1.0).abs() < 1e-12);
        // v is an eigenvector of the smallest eigenvalue (up to sign, or any
        // vector of the eigenspace when repeated).
        let res = (a * v - lmin * v).norm();
        assert!(
            res <= 1e-9 * a.amax().max(1e-300),
            "{a} -> {v}: residual {res}"
        );
    }

    #[test]
    fn matches_an_iterative_solver() {
        let r = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        for diag in [
            [1.0, 0.5, 1e-6],
            [2.0, 2.0, 1e-3],
            [1.0, 1e-9, 1e-9],
            [3.0, 3.0, 3.0],
            [0.0, 0.0, 0.0],
            [1e-8, 4e-9, 0.0],
            [5e4, 1.0, 0.3],
        ] {
            let a =
                r.matrix() * Matrix3::from_diagonal(&Vector3::from(diag)) * r.matrix().transpose();
            check(a);
            check(Matrix3::from_diagonal(&Vector3::from(diag)));
        }
        // Points on a plane with a tilted normal.
        let n = smallest_eigenvector(&Matrix3::new(2.0, 1.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0));
        assert!((n.z.abs() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn plane_covariance_eigenvalues() {
        let n = Vector3::new(1.0, 2.0, 2.0) / 3.0;
        let c = plane_covariance(&n, PLANE_EPSILON);
        assert!(((c * n) - PLANE_EPSILON * n).norm() < 1e-15);
        let t = Vector3::new(2.0, -1.0, 0.0) / 5f64.sqrt();
        assert!(((c * t) - t).norm() < 1e-15);
    }
}
