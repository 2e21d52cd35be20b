//! `speleo mesh --scans DIR --poses POSES.txt`: a TSDF mesh of a folder of
//! PLY scans (sensor frame, taken in name order) with one KITTI pose per
//! line (a row-major 3x4 sensor -> world). The scans are read first, so the
//! times printed are the integration and the meshing alone.

use std::path::{Path, PathBuf};

use serde::Serialize;
use speleo_mapping::tsdf::TsdfParams;

use crate::Error;
use speleo_firmware::maps_output::{mesh_scans, write_mesh, MeshResult};

/// What `--report` writes.
#[derive(Serialize, Debug, Default)]
pub struct MeshReport {
    pub source: String,
    pub scans: usize,
    pub points: u64,
    pub points_integrated: u64,
    pub voxel_m: f64,
    pub truncation_voxels: f64,
    pub tsdf_blocks: usize,
    pub tsdf_full: bool,
    pub vertices: usize,
    pub triangles: usize,
    pub integrate_s: f64,
    pub mesh_s: f64,
    pub total_s: f64,
    pub memory_bytes: usize,
}

impl MeshReport {
    pub fn new(source: String, scans: usize, points: u64, p: &TsdfParams, m: &MeshResult) -> Self {
        MeshReport {
            source,
            scans,
            points,
            points_integrated: m.points,
            voxel_m: p.voxel_size_m,
            truncation_voxels: p.truncation_voxels,
            tsdf_blocks: m.blocks,
            tsdf_full: m.full,
            vertices: m.mesh.vertices.len(),
            triangles: m.mesh.triangles.len(),
            integrate_s: m.integrate_s,
            mesh_s: m.mesh_s,
            total_s: m.integrate_s + m.mesh_s,
            memory_bytes: m.memory_bytes,
        }
    }
}

/// The PLY files of a folder, by name.
fn scan_files(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let entries =
        std::fs::read_dir(dir).map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
    let mut files = Vec::new();
    for e in entries {
        let p = e
            .map_err(|e| format!("cannot read {}: {e}", dir.display()))?
            .path();
        if p.extension().is_some_and(|x| x.eq_ignore_ascii_case("ply")) {
            files.push(p);
        }
    }
    files.sort();
    if files.is_empty() {
        return Err(format!("{}: no .ply scans", dir.display()).into());
    }
    Ok(files)
}

/// One pose per non-empty line: 12 numbers, a row-major 3x4 [R | t].
/// Refused unless R is a rotation within 1e-4.
pub fn parse_kitti(text: &str) -> Result<Vec<nalgebra::Isometry3<f64>>, String> {
    let mut poses = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|t| t.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("line {}: {e}", i + 1))?;
        if v.len() != 12 || !v.iter().all(|x| x.is_finite()) {
            return Err(format!(
                "line {}: a pose is 12 finite numbers (row-major 3x4), got {}",
                i + 1,
                v.len()
            ));
        }
        let r = nalgebra::Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]);
        let orthonormal = (r.transpose() * r - nalgebra::Matrix3::identity()).amax() < 1e-4;
        if !orthonormal || r.determinant() < 0.0 {
            return Err(format!("line {}: the 3x3 part is not a rotation", i + 1));
        }
        let rot = nalgebra::UnitQuaternion::from_matrix(&r);
        poses.push(nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::new(v[3], v[7], v[11]),
            rot,
        ));
    }
    Ok(poses)
}

/// Read the scans and poses, mesh, write. Returns the figures.
pub fn from_scans(
    dir: &Path,
    poses_file: &Path,
    params: TsdfParams,
    out: &Path,
) -> Result<MeshReport, Error> {
    let files = scan_files(dir)?;
    let text = std::fs::read_to_string(poses_file)
        .map_err(|e| format!("cannot read {}: {e}", poses_file.display()))?;
    let poses = parse_kitti(&text).map_err(|e| format!("{}: {e}", poses_file.display()))?;
    if poses.len() != files.len() {
        return Err(format!(
            "{} has {} poses for {} scans in {}",
            poses_file.display(),
            poses.len(),
            files.len(),
            dir.display()
        )
        .into());
    }
    // Every scan in the world frame before the clock starts.
    let mut scans = Vec::with_capacity(files.len());
    let mut points = 0u64;
    for (f, pose) in files.iter().zip(&poses) {
        let bytes = std::fs::read(f).map_err(|e| format!("cannot read {}: {e}", f.display()))?;
        let cloud = speleo_physics::terrain::ply::parse(&bytes)
            .map_err(|e| format!("{}: {e}", f.display()))?;
        points += cloud.vertices.len() as u64;
        let world: Vec<[f64; 3]> = cloud
            .vertices
            .iter()
            .map(|v| {
                let p = pose * nalgebra::Point3::new(v[0] as f64, v[1] as f64, v[2] as f64);
                [p.x, p.y, p.z]
            })
            .collect();
        scans.push((pose.translation.vector.into(), world));
    }
    let m = mesh_scans(params.clone(), scans.len(), |i, buf| {
        let (origin, pts) = &scans[i];
        buf.clear();
        buf.extend_from_slice(pts);
        Some(*origin)
    })?;
    write_mesh(out, &m.mesh)?;
    Ok(MeshReport::new(
        dir.display().to_string(),
        files.len(),
        points,
        &params,
        &m,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kitti_poses_are_read_and_bad_ones_refused() {
        let p = parse_kitti("1 0 0 1.5 0 1 0 -2 0 0 1 0.25\n\n0 -1 0 0 1 0 0 0 0 0 1 0\n")
            .unwrap_or_default();
        assert_eq!(p.len(), 2);
        assert_eq!(
            p[0].translation.vector,
            nalgebra::Vector3::new(1.5, -2.0, 0.25)
        );
        assert!((p[1].rotation.angle() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        for (bad, why) in [
            ("1 0 0 0 0 1 0 0 0 0 1\n", "12 finite numbers"),
            ("1 0 0 0 0 1 0 0 0 0 1 x\n", "line 1"),
            ("2 0 0 0 0 1 0 0 0 0 1 0\n", "not a rotation"),
            ("1 0 0 0 0 1 0 0 0 0 -1 0\n", "not a rotation"),
            ("1 0 0 nan 0 1 0 0 0 0 1 0\n", "12 finite numbers"),
        ] {
            let e = parse_kitti(bad).err().unwrap_or_default();
            assert!(e.contains(why), "{bad:?}: {e}");
        }
    }
}
