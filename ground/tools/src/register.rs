//! `speleo register`: Generalized-ICP between two PLY point clouds (the
//! `vertex` x, y, z of ASCII or binary files; faces, if any, are ignored),
//! with the same preprocessing and solver the on-board SLAM uses.

use std::path::Path;
use std::time::Instant;

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::Serialize;
use speleo_slam::registration::covariance::DEFAULT_NEIGHBORS;
use speleo_slam::registration::{align, GicpParams, PreparedCloud};

use crate::Error;

/// What `register` found, for `--json` or a table.
#[derive(Clone, Debug, Serialize)]
pub struct RegisterReport {
    /// target <- source, 4x4 row-major.
    pub transform: [[f64; 4]; 4],
    pub iterations: u32,
    pub converged: bool,
    /// RMS distance of inlier correspondences, metres.
    pub fitness_m: f64,
    pub inlier_fraction: f64,
    /// Vertices read from each file.
    pub source_points: usize,
    pub target_points: usize,
    /// Points left after voxel downsampling (and dropping non-finite ones).
    pub source_downsampled: usize,
    pub target_downsampled: usize,
    pub voxel_m: f64,
    /// Downsampling, kd-trees and covariances of both clouds.
    pub prepare_ms: f64,
    pub align_ms: f64,
}

/// Register `source` onto `target` from the initial guess in `init` (4x4
/// row-major, 16 whitespace-separated numbers; identity when absent) with
/// voxels of `voxel_m` metres (0: no downsampling).
pub fn register(
    source: &Path,
    target: &Path,
    init: Option<&Path>,
    voxel_m: f64,
) -> Result<RegisterReport, Error> {
    if !(voxel_m >= 0.0 && voxel_m.is_finite()) {
        return Err(format!("voxel size {voxel_m} m: must be a finite number >= 0").into());
    }
    let init = match init {
        Some(p) => read_transform(p)?,
        None => Isometry3::identity(),
    };
    let src = read_points(source)?;
    let tgt = read_points(target)?;
    let started = Instant::now();
    let mut s = PreparedCloud::with_capacity(src.len());
    let mut t = PreparedCloud::with_capacity(tgt.len());
    s.prepare(src.iter().copied(), voxel_m);
    t.prepare(tgt.iter().copied(), voxel_m);
    let prepared = Instant::now();
    // Each point's covariance is fitted to its nearest neighbours: fewer
    // points than that give no surface to align, only a fit to anything.
    if s.len() < DEFAULT_NEIGHBORS || t.len() < DEFAULT_NEIGHBORS {
        return Err(format!(
            "too few points to register: {} usable source and {} usable target points after voxels of {voxel_m} m (GICP needs at least {DEFAULT_NEIGHBORS} in each; a smaller --voxel keeps more)",
            s.len(),
            t.len()
        )
        .into());
    }
    let a = align(&s, &t, &init, &GicpParams::default());
    let done = Instant::now();
    let m = a.transform.to_homogeneous();
    let mut transform = [[0.0; 4]; 4];
    for (r, row) in transform.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = m[(r, c)];
        }
    }
    Ok(RegisterReport {
        transform,
        iterations: a.iterations,
        converged: a.converged,
        fitness_m: a.fitness,
        inlier_fraction: a.inlier_fraction,
        source_points: src.len(),
        target_points: tgt.len(),
        source_downsampled: s.len(),
        target_downsampled: t.len(),
        voxel_m,
        prepare_ms: (prepared - started).as_secs_f64() * 1e3,
        align_ms: (done - prepared).as_secs_f64() * 1e3,
    })
}

/// Vertices of a PLY file. The mesh loader (`Mesh::load`) drops vertices no
/// face uses, so the parser is called directly: a vertex-only file is fine.
fn read_points(path: &Path) -> Result<Vec<[f64; 3]>, Error> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let mesh = speleo_physics::terrain::ply::parse(&bytes)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(mesh
        .vertices
        .iter()
        .map(|v| [v[0] as f64, v[1] as f64, v[2] as f64])
        .collect())
}

/// A rigid 4x4 transform, row-major. Refused unless the rotation block is
/// orthonormal with determinant +1 (within 1e-6) and the last row 0 0 0 1.
fn read_transform(path: &Path) -> Result<Isometry3<f64>, Error> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    parse_transform(&text).map_err(|e| format!("{}: {e}", path.display()).into())
}

fn parse_transform(text: &str) -> Result<Isometry3<f64>, String> {
    let v: Vec<f64> = text
        .split_whitespace()
        .map(|w| {
            w.parse::<f64>()
                .map_err(|_| format!("\"{w}\" is not a number"))
        })
        .collect::<Result<_, _>>()?;
    if v.len() != 16 {
        return Err(format!("{} numbers, a 4x4 transform has 16", v.len()));
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err("a number is not finite".into());
    }
    let r = Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]);
    let orth = (r.transpose() * r - Matrix3::identity()).amax();
    if orth > 1e-6 || (r.determinant() - 1.0).abs() > 1e-6 {
        return Err("the upper-left 3x3 block is not a rotation".into());
    }
    if v[12..16] != [0.0, 0.0, 0.0, 1.0] {
        return Err("the last row is not 0 0 0 1".into());
    }
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Ok(Isometry3::from_parts(
        Translation3::from(Vector3::new(v[3], v[7], v[11])),
        q,
    ))
}

impl std::fmt::Display for RegisterReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "transform (target <- source):")?;
        for row in &self.transform {
            writeln!(
                f,
                "  {:12.6} {:12.6} {:12.6} {:12.6}",
                row[0], row[1], row[2], row[3]
            )?;
        }
        writeln!(
            f,
            "{} iterations ({}), fitness {:.4} m, inliers {:.1}%",
            self.iterations,
            if self.converged {
                "converged"
            } else {
                "not converged"
            },
            self.fitness_m,
            100.0 * self.inlier_fraction
        )?;
        write!(
            f,
            "points {} -> {} and {} -> {} at {} m voxels; prepare {:.1} ms + align {:.1} ms = {:.1} ms",
            self.source_points,
            self.source_downsampled,
            self.target_points,
            self.target_downsampled,
            self.voxel_m,
            self.prepare_ms,
            self.align_ms,
            self.prepare_ms + self.align_ms
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box room's surfaces on a 5 cm grid.
    fn room() -> Vec<[f64; 3]> {
        let mut out = Vec::new();
        let (lo, hi) = ([-4.0, -3.0, -1.0], [4.0, 3.0, 2.0]);
        for axis in 0..3 {
            for side in [lo[axis], hi[axis]] {
                let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
                let nu = ((hi[u] - lo[u]) / 0.05) as usize;
                let nw = ((hi[w] - lo[w]) / 0.05) as usize;
                for i in 0..nu {
                    for j in 0..nw {
                        let mut p = [0.0; 3];
                        p[axis] = side;
                        p[u] = lo[u] + i as f64 * 0.05;
                        p[w] = lo[w] + j as f64 * 0.05;
                        out.push(p);
                    }
                }
            }
        }
        // A pillar, so that no direction is free.
        for i in 0..60 {
            for k in 0..12 {
                let a = k as f64 * std::f64::consts::TAU / 12.0;
                out.push([
                    1.0 + 0.3 * a.cos(),
                    0.5 + 0.3 * a.sin(),
                    -1.0 + i as f64 * 0.05,
                ]);
            }
        }
        out
    }

    fn write_ply(path: &Path, pts: &[[f64; 3]], binary: bool) {
        let fmt = if binary {
            "binary_little_endian"
        } else {
            "ascii"
        };
        let mut b = format!(
            "ply\nformat {fmt} 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            pts.len()
        )
        .into_bytes();
        for p in pts {
            if binary {
                for x in p {
                    b.extend_from_slice(&(*x as f32).to_le_bytes());
                }
            } else {
                b.extend_from_slice(format!("{} {} {}\n", p[0], p[1], p[2]).as_bytes());
            }
        }
        std::fs::write(path, b).expect("writes");
    }

    #[test]
    fn registers_vertex_only_ply_files() {
        let dir = tempfile::tempdir().expect("tempdir");
        let target = room();
        let truth = Isometry3::from_parts(
            Translation3::new(0.2, -0.1, 0.05),
            UnitQuaternion::from_euler_angles(0.01, 0.02, 0.08),
        );
        let source: Vec<[f64; 3]> = target
            .iter()
            .map(|p| {
                let q = truth.inverse() * nalgebra::Point3::new(p[0], p[1], p[2]);
                [q.x, q.y, q.z]
            })
            .collect();
        let (s, t, init) = (
            dir.path().join("s.ply"),
            dir.path().join("t.ply"),
            dir.path().join("init.txt"),
        );
        write_ply(&s, &source, true);
        write_ply(&t, &target, false);
        std::fs::write(&init, "1 0 0 0.1\n0 1 0 0\n0 0 1 0\n0 0 0 1\n").expect("writes");
        let r = register(&s, &t, Some(&init), 0.1).expect("registers");
        assert!(r.converged, "{r:?}");
        assert_eq!(
            (r.source_points, r.target_points),
            (source.len(), target.len())
        );
        let m = truth.to_homogeneous();
        for (i, row) in r.transform.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!((v - m[(i, j)]).abs() < 2e-3, "{r:?}");
            }
        }
        let json = serde_json::to_string(&r).expect("serialises");
        assert!(json.contains("\"fitness_m\""));
    }

    #[test]
    fn bad_input_is_refused() {
        let dir = tempfile::tempdir().expect("tempdir");
        let t = dir.path().join("t.ply");
        write_ply(&t, &room(), false);
        let missing = dir.path().join("missing.ply");
        assert!(register(&missing, &t, None, 0.1).is_err());
        let empty = dir.path().join("empty.ply");
        write_ply(&empty, &[], false);
        assert!(register(&empty, &t, None, 0.1).is_err());
        assert!(register(&t, &t, None, f64::NAN).is_err());
        assert!(parse_transform("1 0 0 0 0 1 0 0 0 0 1 0 0 0 0").is_err());
        assert!(parse_transform("2 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1").is_err());
        assert!(parse_transform("1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1").is_err());
        assert!(parse_transform("1 0 0 x 0 1 0 0 0 0 1 0 0 0 0 1").is_err());
        let ok = parse_transform("0 -1 0 1\n1 0 0 2\n0 0 1 3\n0 0 0 1").expect("valid");
        assert!((ok.rotation.angle() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(ok.translation.vector, Vector3::new(1.0, 2.0, 3.0));
    }
}
