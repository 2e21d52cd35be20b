//! The g2o text format for pose graphs: `VERTEX_SE2`, `EDGE_SE2`,
//! `VERTEX_SE3:QUAT`, `EDGE_SE3:QUAT` and `FIX`; files with edges only are
//! accepted (their vertices are created at the identity). Also the two costs
//! of a graph: g2o's chi2 and the SE-Sync objective.

use nalgebra::{Matrix3, Matrix6, Quaternion, UnitQuaternion, Vector3};

use crate::lie::Pose;

/// 2D (SE2) or 3D (SE3) graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dim {
    Two,
    Three,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Edge {
    /// Indices into [`G2o::ids`].
    pub i: usize,
    pub j: usize,
    pub z: Pose,
    /// Over `[t; rotation]` as the file gives it: 3x3 (x, y, theta) in the
    /// upper-left corner for 2D, 6x6 for 3D (rotation part over the
    /// quaternion's vector part, as g2o defines its error).
    pub info: Matrix6<f64>,
}

/// A parsed g2o file.
#[derive(Clone, Debug, PartialEq)]
pub struct G2o {
    pub dim: Dim,
    /// Vertex ids in ascending order; a vertex's index is its position here.
    pub ids: Vec<u64>,
    pub poses: Vec<Pose>,
    /// Whether the file gave the vertex (edges-only files give none).
    pub given: Vec<bool>,
    pub fixed: Vec<bool>,
    pub edges: Vec<Edge>,
    /// Lines with a tag this reader does not use (parameters, landmarks).
    pub skipped_lines: usize,
}

#[derive(Debug, Clone, PartialEq)]
pub struct G2oError {
    pub line: usize,
    pub why: String,
}

impl std::fmt::Display for G2oError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}: {}", self.line, self.why)
    }
}

impl std::error::Error for G2oError {}

#[allow(clippy::large_enum_variant)] // parse-time only
enum Raw {
    Vertex(u64, Pose),
    Edge(u64, u64, Pose, Matrix6<f64>),
    Fix(u64),
}

fn numbers<const N: usize>(it: &mut std::str::SplitWhitespace<'_>) -> Result<[f64; N], String> {
    let mut out = [0.0f64; N];
    for (k, o) in out.iter_mut().enumerate() {
        let s = it
            .next()
            .ok_or_else(|| format!("expected {N} numbers, found {k}"))?;
        *o = s.parse().map_err(|_| format!("\"{s}\" is not a number"))?;
        if !o.is_finite() {
            return Err(format!("\"{s}\" is not finite"));
        }
    }
    Ok(out)
}

fn id(it: &mut std::str::SplitWhitespace<'_>) -> Result<u64, String> {
    let s = it.next().ok_or("missing vertex id")?;
    s.parse().map_err(|_| format!("\"{s}\" is not a vertex id"))
}

fn quat(x: f64, y: f64, z: f64, w: f64) -> Result<Matrix3<f64>, String> {
    let q = Quaternion::new(w, x, y, z);
    let n = q.norm();
    if !(0.5..=1.5).contains(&n) {
        return Err(format!("quaternion of norm {n} is not a rotation"));
    }
    Ok(*UnitQuaternion::from_quaternion(q)
        .to_rotation_matrix()
        .matrix())
}

fn upper(v: &[f64], n: usize) -> Matrix6<f64> {
    let mut m = Matrix6::zeros();
    let mut k = 0;
    for r in 0..n {
        for c in r..n {
            m[(r, c)] = v[k];
            m[(c, r)] = v[k];
            k += 1;
        }
    }
    m
}

fn parse_line(
    tag: &str,
    it: &mut std::str::SplitWhitespace<'_>,
) -> Result<Option<(Dim, Raw)>, String> {
    Ok(Some(match tag {
        "VERTEX_SE2" => {
            let i = id(it)?;
            let [x, y, th] = numbers::<3>(it)?;
            (Dim::Two, Raw::Vertex(i, Pose::planar(x, y, th)))
        }
        "EDGE_SE2" => {
            let (i, j) = (id(it)?, id(it)?);
            let [x, y, th] = numbers::<3>(it)?;
            let inf = numbers::<6>(it)?;
            (
                Dim::Two,
                Raw::Edge(i, j, Pose::planar(x, y, th), upper(&inf, 3)),
            )
        }
        "VERTEX_SE3:QUAT" => {
            let i = id(it)?;
            let [x, y, z, qx, qy, qz, qw] = numbers::<7>(it)?;
            let pose = Pose::new(quat(qx, qy, qz, qw)?, Vector3::new(x, y, z));
            (Dim::Three, Raw::Vertex(i, pose))
        }
        "EDGE_SE3:QUAT" => {
            let (i, j) = (id(it)?, id(it)?);
            let [x, y, z, qx, qy, qz, qw] = numbers::<7>(it)?;
            let inf = numbers::<21>(it)?;
            let pose = Pose::new(quat(qx, qy, qz, qw)?, Vector3::new(x, y, z));
            (Dim::Three, Raw::Edge(i, j, pose, upper(&inf, 6)))
        }
        // FIX applies to either dimension; the caller ignores its `Dim`.
        "FIX" => (Dim::Three, Raw::Fix(id(it)?)),
        _ => return Ok(None),
    }))
}

impl G2o {
    /// Parse a whole file.
    pub fn parse(text: &str) -> Result<G2o, G2oError> {
        let mut dim = None;
        let mut raws = Vec::new();
        let mut skipped_lines = 0;
        for (n, line) in text.lines().enumerate() {
            let err = |why: String| G2oError { line: n + 1, why };
            let mut it = line.split_whitespace();
            let Some(tag) = it.next() else { continue };
            if tag.starts_with('#') {
                continue;
            }
            match parse_line(tag, &mut it).map_err(err)? {
                None => skipped_lines += 1,
                Some((d, raw)) => {
                    if !matches!(raw, Raw::Fix(_)) {
                        if dim.is_some_and(|x| x != d) {
                            return Err(G2oError {
                                line: n + 1,
                                why: "2D and 3D elements mixed in one file".into(),
                            });
                        }
                        dim = Some(d);
                    }
                    raws.push((n + 1, raw));
                }
            }
        }
        let dim = dim.ok_or(G2oError {
            line: 0,
            why: "no vertices or edges".into(),
        })?;
        let mut ids: Vec<u64> = raws
            .iter()
            .flat_map(|(_, r)| match *r {
                Raw::Vertex(i, _) | Raw::Fix(i) => [Some(i), None],
                Raw::Edge(i, j, ..) => [Some(i), Some(j)],
            })
            .flatten()
            .collect();
        ids.sort_unstable();
        ids.dedup();
        let index = |i: u64| ids.binary_search(&i).unwrap_or(0);
        let n = ids.len();
        let mut g = G2o {
            dim,
            poses: vec![Pose::identity(); n],
            given: vec![false; n],
            fixed: vec![false; n],
            edges: Vec::new(),
            ids: Vec::new(),
            skipped_lines,
        };
        let mut edge_lines = Vec::new();
        for (line, r) in raws {
            match r {
                Raw::Vertex(i, p) => {
                    let k = index(i);
                    g.poses[k] = p;
                    g.given[k] = true;
                }
                Raw::Fix(i) => g.fixed[index(i)] = true,
                Raw::Edge(i, j, z, info) => {
                    g.edges.push(Edge {
                        i: index(i),
                        j: index(j),
                        z,
                        info,
                    });
                    edge_lines.push(line);
                }
            }
        }
        g.ids = ids;
        g.check_edges(&edge_lines)?;
        Ok(g)
    }

    /// The first vertex (by index) that no chain of edges joins to any of
    /// `roots`: its pose, and its component's, is left undetermined.
    pub fn first_unjoined(&self, roots: &[usize]) -> Option<usize> {
        let n = self.ids.len();
        let mut parent: Vec<usize> = (0..n).collect();
        fn find(parent: &mut [usize], mut k: usize) -> usize {
            while parent[k] != k {
                parent[k] = parent[parent[k]];
                k = parent[k];
            }
            k
        }
        for e in &self.edges {
            let (a, b) = (find(&mut parent, e.i), find(&mut parent, e.j));
            parent[a.max(b)] = a.min(b);
        }
        let rooted: Vec<usize> = roots.iter().map(|&r| find(&mut parent, r)).collect();
        (0..n).find(|&k| {
            let c = find(&mut parent, k);
            !rooted.contains(&c)
        })
    }

    /// Each edge (from line `lines[k]`) joins vertices the file gives, when
    /// it gives any, and weighs both its rotation and its translation: an
    /// edge to a vertex no line gives is a typo in a file with vertices,
    /// and a singular information block leaves the pose undetermined.
    fn check_edges(&self, lines: &[usize]) -> Result<(), G2oError> {
        let any_given = self.given.iter().any(|g| *g);
        for (e, &line) in self.edges.iter().zip(lines) {
            if any_given {
                if let Some(k) = [e.i, e.j].into_iter().find(|&k| !self.given[k]) {
                    return Err(G2oError {
                        line,
                        why: format!(
                            "edge to vertex {}, which no vertex line gives (a file with vertices must give every vertex its edges join)",
                            self.ids[k]
                        ),
                    });
                }
            }
            let (kappa, tau) = self.sesync_weights(e);
            if !(kappa > 0.0 && tau > 0.0 && kappa.is_finite() && tau.is_finite()) {
                return Err(G2oError {
                    line,
                    why: "the edge's information matrix is not positive definite (its rotation or translation block is zero or singular)".into(),
                });
            }
        }
        Ok(())
    }

    /// Write the graph (with `poses` as its vertices) in the file's own
    /// dimension. Numbers are printed in their shortest exact form, so a
    /// written file parses back to the same values.
    pub fn write(&self, poses: &[Pose], out: &mut dyn std::io::Write) -> std::io::Result<()> {
        for (k, p) in poses.iter().enumerate() {
            let id = self.ids[k];
            match self.dim {
                Dim::Two => writeln!(out, "VERTEX_SE2 {id} {} {} {}", p.t.x, p.t.y, p.yaw())?,
                Dim::Three => {
                    let q = to_quat(&p.r);
                    writeln!(
                        out,
                        "VERTEX_SE3:QUAT {id} {} {} {} {} {} {} {}",
                        p.t.x, p.t.y, p.t.z, q.i, q.j, q.k, q.w
                    )?
                }
            }
        }
        for e in &self.edges {
            let (a, b) = (self.ids[e.i], self.ids[e.j]);
            match self.dim {
                Dim::Two => {
                    write!(
                        out,
                        "EDGE_SE2 {a} {b} {} {} {}",
                        e.z.t.x,
                        e.z.t.y,
                        e.z.yaw()
                    )?;
                    write_upper(out, &e.info, 3)?;
                }
                Dim::Three => {
                    let q = to_quat(&e.z.r);
                    write!(
                        out,
                        "EDGE_SE3:QUAT {a} {b} {} {} {} {} {} {} {}",
                        e.z.t.x, e.z.t.y, e.z.t.z, q.i, q.j, q.k, q.w
                    )?;
                    write_upper(out, &e.info, 6)?;
                }
            }
            writeln!(out)?;
        }
        for (k, f) in self.fixed.iter().enumerate() {
            if *f {
                writeln!(out, "FIX {}", self.ids[k])?;
            }
        }
        Ok(())
    }

    /// g2o's chi2 of `poses`: sum of e^T I e with g2o's own errors
    /// (2D: [R_z^T (R_i^T (t_j - t_i) - t_z); wrapped angle]; 3D:
    /// [translation error; vector part of the error quaternion, w >= 0]).
    pub fn chi2(&self, poses: &[Pose]) -> f64 {
        let mut sum = 0.0;
        for e in &self.edges {
            let rel = poses[e.i].between(&poses[e.j]);
            let err = e.z.between(&rel);
            let mut v = nalgebra::Vector6::zeros();
            match self.dim {
                Dim::Two => {
                    v[0] = err.t.x;
                    v[1] = err.t.y;
                    v[2] = err.yaw();
                    let m = e.info.fixed_view::<3, 3>(0, 0);
                    let x = v.fixed_rows::<3>(0);
                    sum += (x.transpose() * m * x)[0];
                }
                Dim::Three => {
                    let q = to_quat(&err.r);
                    v.fixed_rows_mut::<3>(0).copy_from(&err.t);
                    v.fixed_rows_mut::<3>(3).copy_from(&q.imag());
                    sum += (v.transpose() * e.info * v)[0];
                }
            }
        }
        sum
    }

    /// The SE-Sync weights (kappa, tau) of an edge, from its information
    /// matrix (see ../shared/data/README.md for the definition).
    pub fn sesync_weights(&self, e: &Edge) -> (f64, f64) {
        match self.dim {
            Dim::Two => {
                let itt = e.info.fixed_view::<2, 2>(0, 0).into_owned();
                let tau = itt.try_inverse().map_or(0.0, |m| 2.0 / m.trace());
                (e.info[(2, 2)], tau)
            }
            Dim::Three => {
                let itt = e.info.fixed_view::<3, 3>(0, 0).into_owned();
                let irr = e.info.fixed_view::<3, 3>(3, 3).into_owned();
                let tau = itt.try_inverse().map_or(0.0, |m| 3.0 / m.trace());
                let kappa = irr.try_inverse().map_or(0.0, |m| 3.0 / (2.0 * m.trace()));
                (kappa, tau)
            }
        }
    }

    /// The SE-Sync objective of `poses`:
    /// sum kappa |R_j - R_i R_z|_F^2 + tau |t_j - t_i - R_i t_z|^2.
    pub fn sesync_objective(&self, poses: &[Pose]) -> f64 {
        self.edges
            .iter()
            .map(|e| {
                let (kappa, tau) = self.sesync_weights(e);
                let (pi, pj) = (&poses[e.i], &poses[e.j]);
                kappa * (pj.r - pi.r * e.z.r).norm_squared()
                    + tau * (pj.t - pi.t - pi.r * e.z.t).norm_squared()
            })
            .sum()
    }
}

fn to_quat(r: &Matrix3<f64>) -> UnitQuaternion<f64> {
    let q = UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(*r));
    if q.w < 0.0 {
        UnitQuaternion::new_unchecked(-q.into_inner())
    } else {
        q
    }
}

fn write_upper(out: &mut dyn std::io::Write, m: &Matrix6<f64>, n: usize) -> std::io::Result<()> {
    for r in 0..n {
        for c in r..n {
            write!(out, " {}", m[(r, c)])?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const TINY_3D: &str = "\
VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1
VERTEX_SE3:QUAT 1 1 0 0 0 0 0.7071067811865476 0.7071067811865476
EDGE_SE3:QUAT 0 1 1 0.1 0 0 0 0.7071067811865476 0.7071067811865476 4 0 0 0 0 0 4 0 0 0 0 4 0 0 0 10 0 0 10 0 10
FIX 0
";

    #[test]
    fn sesync_objective_of_a_tiny_graph_by_hand() {
        let g = G2o::parse(TINY_3D).expect("parse");
        assert_eq!(g.poses.len(), 2);
        assert!(g.fixed[0] && !g.fixed[1]);
        // Rotations agree exactly; the translation misses by 0.1 m in y.
        // tau = 3 / trace(inv(4 I)) = 3 / 0.75 = 4; so F = 4 * 0.01.
        let f = g.sesync_objective(&g.poses);
        assert!((f - 0.04).abs() < 1e-12, "{f}");
        // kappa = 3 / (2 * 0.3) = 5: a 0.1 rad error about z adds
        // 5 * |R(0.1) - I|_F^2 = 5 * (2 (1 - cos 0.1)^2 + 2 sin^2 0.1).
        let mut p = g.poses.clone();
        p[1].r *= crate::lie::exp_so3(&Vector3::new(0.0, 0.0, 0.1));
        let expect = 0.04 + 5.0 * (2.0 * (1.0 - 0.1f64.cos()).powi(2) + 2.0 * 0.1f64.sin().powi(2));
        let got = g.sesync_objective(&p);
        // The rotated pose also changes nothing in translation (t_j fixed).
        assert!((got - expect).abs() < 1e-12, "{got} vs {expect}");
    }

    #[test]
    fn files_round_trip_in_both_dimensions() {
        let two = "VERTEX_SE2 3 1.5 -2 0.25\nVERTEX_SE2 7 0 0 -3\nEDGE_SE2 3 7 0.1 0.2 -0.3 11 0.5 0 12 0 13\n";
        for text in [TINY_3D, two] {
            let g = G2o::parse(text).expect("parse");
            let mut out = Vec::new();
            g.write(&g.poses, &mut out).expect("write");
            let back = G2o::parse(std::str::from_utf8(&out).expect("utf8")).expect("reparse");
            assert_eq!(back.ids, g.ids);
            assert_eq!(back.edges.len(), g.edges.len());
            for (a, b) in back.poses.iter().zip(&g.poses) {
                assert!((a.r - b.r).norm() < 1e-15 && (a.t - b.t).norm() < 1e-15);
            }
            for (a, b) in back.edges.iter().zip(&g.edges) {
                assert_eq!(a.info, b.info);
                assert!((a.z.t - b.z.t).norm() < 1e-15 && (a.z.r - b.z.r).norm() < 1e-15);
            }
        }
    }

    #[test]
    fn edges_only_files_and_bad_lines() {
        let g = G2o::parse("EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n")
            .expect("edges only");
        assert_eq!(g.poses.len(), 3);
        assert!(g.given.iter().all(|g| !g));
        let e = G2o::parse("VERTEX_SE2 0 0 0\n").expect_err("short");
        assert_eq!(e.line, 1);
        assert!(G2o::parse("VERTEX_SE2 0 0 0 nan\n").is_err());
        assert!(G2o::parse("VERTEX_SE2 0 0 0 0\nVERTEX_SE3:QUAT 1 0 0 0 0 0 0 1\n").is_err());
        assert!(G2o::parse("").is_err());
        let g = G2o::parse("PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\nVERTEX_SE2 0 0 0 0\n").expect("skip");
        assert_eq!(g.skipped_lines, 1);
    }

    #[test]
    fn an_edge_to_a_vertex_not_given_or_without_weight_is_named_by_its_line() {
        let vertices = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";
        let e = G2o::parse(&format!("{vertices}EDGE_SE2 1 5 1 0 0 1 0 0 1 0 1\n"))
            .expect_err("missing vertex");
        assert_eq!(e.line, 3);
        assert!(e.why.contains("vertex 5"), "{e}");
        for info in [
            "0 0 0 0 0 0",
            "1 0 1 0 0 0",
            "0 0 0 0 0 1",
            "-1 0 -1 0 0 -1",
        ] {
            let e = G2o::parse(&format!("{vertices}EDGE_SE2 0 1 1 0 0 {info}\n")).expect_err(info);
            assert_eq!(e.line, 3, "{info}");
            assert!(e.why.contains("not positive definite"), "{e}");
        }
        let zero_3d = format!(
            "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nEDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1{}\n",
            " 0".repeat(21)
        );
        // Edges-only files create their vertices; a zero weight is refused.
        assert!(
            G2o::parse(&zero_3d.replacen("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n", "", 1))
                .is_err_and(|e| e.line == 1 && e.why.contains("not positive definite"))
        );
        assert!(G2o::parse(&zero_3d).is_err_and(|e| e.why.contains("vertex 1")));
    }

    #[test]
    fn a_vertex_no_edge_chain_joins_to_the_roots_is_found() {
        let g = G2o::parse(
            "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 2 3 1 0 0 1 0 0 1 0 1\nEDGE_SE2 3 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 4 5 1 0 0 1 0 0 1 0 1\n",
        )
        .expect("parse");
        assert_eq!(g.first_unjoined(&[0]), Some(4));
        assert_eq!(g.first_unjoined(&[0, 5]), None);
    }
}
