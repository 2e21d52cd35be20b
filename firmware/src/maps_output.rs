//! What becomes of the maps after a run: the report's `maps` section, the
//! TSDF mesh of every keyframe (`--mesh`), and the keyframes as PLY scans
//! with KITTI poses (`--export-scans`, the input of `speleo mesh --scans`).

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use serde::Serialize;
use speleo_mapping::marching_cubes::{write_ply, Mesh, MeshBuffers};
use speleo_mapping::tsdf::{TsdfParams, TsdfVolume};

/// The maps at the end of a run: the MLS map's figures, and the keyframe
/// clouds with their final poses, for a mesh or an export.
pub struct MapsResult {
    pub mls: speleo_mapping::mls::MlsStats,
    pub memory_bytes: usize,
    pub counters: speleo_mapping::MapsCounters,
    pub keyframes: speleo_mapping::KeyframeClouds,
    /// The LiDAR mount, base <- sensor (the clouds are in the base frame).
    pub mount: speleo_slam::lie::Pose,
}

type Error = Box<dyn std::error::Error>;

/// The report's `maps` section.
#[derive(Clone, Debug, Default, Serialize)]
pub struct MapsFigures {
    /// The multi-level surface map that serves at the end of the run.
    pub mls_cells: usize,
    pub mls_patches: usize,
    pub mls_full: bool,
    pub mls_points_dropped: u64,
    pub keyframes_mapped: usize,
    pub reprojections: u64,
    /// Rebuilds that kept only the region around the rover (the map was
    /// full), and the points they left out.
    pub regions_kept: u64,
    pub points_outside_region: u64,
    /// Cells marked where a keyframe's rings should have met the rover's
    /// ground and met nothing (`maps.unseen_ground_reach_m`).
    pub unseen_ground_marks: u64,
    /// Keyframe points that did not fit the keyframe clouds.
    pub keyframe_points_dropped: u64,
    /// The TSDF of every keyframe and its mesh (made when a report or a
    /// mesh is asked for).
    pub tsdf_blocks: usize,
    pub tsdf_full: bool,
    pub mesh_vertices: usize,
    pub mesh_triangles: usize,
    /// Fixed memory of the maps: both MLS maps, the keyframe clouds, and
    /// the TSDF and mesh when made.
    pub memory_bytes: usize,
    /// Wall-clock time of the TSDF integration and of the meshing, s
    /// (machine-dependent, informational).
    pub integrate_s: f64,
    pub mesh_s: f64,
}

/// A TSDF mesh and how it was made.
pub struct MeshResult {
    pub mesh: Mesh,
    pub blocks: usize,
    pub full: bool,
    pub points: u64,
    pub integrate_s: f64,
    pub mesh_s: f64,
    pub memory_bytes: usize,
}

/// Integrate `scans` scans into a TSDF and mesh it: `fill(i, buffer)`
/// puts scan `i`'s points (map frame) in the buffer and returns its sensor
/// origin, or `None` to skip it. One buffer serves every scan.
pub fn mesh_scans(
    params: TsdfParams,
    scans: usize,
    mut fill: impl FnMut(usize, &mut Vec<[f64; 3]>) -> Option<[f64; 3]>,
) -> Result<MeshResult, Error> {
    let mut tsdf = TsdfVolume::new(params)?;
    let mut buffer = Vec::new();
    let started = Instant::now();
    let mut points = 0;
    for i in 0..scans {
        if let Some(origin) = fill(i, &mut buffer) {
            points += tsdf.integrate(origin, &buffer).integrated;
        }
    }
    let integrate_s = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let mut buffers = MeshBuffers::new();
    tsdf.mesh_all(&mut buffers);
    let mesh_s = started.elapsed().as_secs_f64();
    let stats = tsdf.stats();
    Ok(MeshResult {
        memory_bytes: stats.memory_bytes + buffers.memory_bytes(),
        mesh: buffers.mesh,
        blocks: stats.blocks,
        full: stats.full,
        points,
        integrate_s,
        mesh_s,
    })
}

/// The TSDF mesh of every keyframe at its final pose.
pub fn mesh_keyframes(params: TsdfParams, maps: &MapsResult) -> Result<MeshResult, Error> {
    let store = &maps.keyframes;
    mesh_scans(params, store.ready(), |k, out| {
        let pose = store.pose(k)?;
        out.clear();
        out.extend(store.cloud(k).map(|p| {
            let v = pose.transform(&nalgebra::Vector3::from(p));
            [v.x, v.y, v.z]
        }));
        Some(pose.compose(&maps.mount).t.into())
    })
}

/// Write a mesh as binary PLY.
pub fn write_mesh(path: &Path, mesh: &Mesh) -> Result<(), Error> {
    let f = std::fs::File::create(path)
        .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
    let mut w = std::io::BufWriter::new(f);
    write_ply(mesh, &mut w).map_err(|e| format!("writing {}: {e}", path.display()))?;
    w.flush()
        .map_err(|e| format!("writing {}: {e}", path.display()))?;
    Ok(())
}

/// Every keyframe as `DIR/NNNNNN.ply` (binary, the sensor frame) and
/// `DIR/poses.txt` (KITTI: a row-major 3x4 map <- sensor per line, in
/// file order). Returns the number of scans written.
pub fn export_scans(dir: &Path, maps: &MapsResult) -> Result<usize, Error> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let store = &maps.keyframes;
    let sensor_from_base = maps.mount.inverse();
    let mut poses = String::new();
    for k in 0..store.ready() {
        let Some(pose) = store.pose(k) else { continue };
        let pts: Vec<[f32; 3]> = store
            .cloud(k)
            .map(|p| {
                let v = sensor_from_base.transform(&nalgebra::Vector3::from(p));
                [v.x as f32, v.y as f32, v.z as f32]
            })
            .collect();
        let path = dir.join(format!("{k:06}.ply"));
        write_points_ply(&path, &pts)?;
        let s = pose.compose(&maps.mount);
        let (r, t) = (s.r, s.t);
        poses.push_str(&format!(
            "{:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e}\n",
            r[(0, 0)],
            r[(0, 1)],
            r[(0, 2)],
            t.x,
            r[(1, 0)],
            r[(1, 1)],
            r[(1, 2)],
            t.y,
            r[(2, 0)],
            r[(2, 1)],
            r[(2, 2)],
            t.z,
        ));
    }
    let p = dir.join("poses.txt");
    std::fs::write(&p, poses).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
    Ok(store.ready())
}

/// A vertex-only binary little-endian PLY.
fn write_points_ply(path: &Path, pts: &[[f32; 3]]) -> Result<(), Error> {
    let f = std::fs::File::create(path)
        .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
    let mut w = std::io::BufWriter::new(f);
    let io = |e: std::io::Error| format!("writing {}: {e}", path.display());
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        pts.len()
    )
    .map_err(io)?;
    for p in pts {
        for c in p {
            w.write_all(&c.to_le_bytes()).map_err(io)?;
        }
    }
    w.flush().map_err(io)?;
    Ok(())
}

/// What a run asks of its maps at the end.
#[derive(Clone, Debug, Default)]
pub struct MapsRequests<'a> {
    /// Make the TSDF mesh (for the report's figures) even without a file.
    pub figures: bool,
    pub mesh: Option<&'a Path>,
    pub export_scans: Option<&'a Path>,
}

/// Carry out the requests; the figures for the report.
pub fn finish(
    maps: &MapsResult,
    tsdf: TsdfParams,
    req: &MapsRequests<'_>,
) -> Result<MapsFigures, Error> {
    let mut f = MapsFigures {
        mls_cells: maps.mls.cells,
        mls_patches: maps.mls.patches,
        mls_full: maps.mls.full,
        mls_points_dropped: maps.mls.dropped_points,
        keyframes_mapped: maps.keyframes.ready(),
        reprojections: maps.counters.reprojections,
        regions_kept: maps.counters.regions_kept,
        points_outside_region: maps.counters.points_outside_region,
        unseen_ground_marks: maps.counters.unseen_ground_marks,
        keyframe_points_dropped: maps.keyframes.dropped,
        memory_bytes: maps.memory_bytes,
        ..MapsFigures::default()
    };
    if let Some(dir) = req.export_scans {
        export_scans(dir, maps)?;
    }
    if req.figures || req.mesh.is_some() {
        let m = mesh_keyframes(tsdf, maps)?;
        if let Some(p) = req.mesh {
            write_mesh(p, &m.mesh)?;
        }
        f.tsdf_blocks = m.blocks;
        f.tsdf_full = m.full;
        f.mesh_vertices = m.mesh.vertices.len();
        f.mesh_triangles = m.mesh.triangles.len();
        f.memory_bytes += m.memory_bytes;
        f.integrate_s = m.integrate_s;
        f.mesh_s = m.mesh_s;
    }
    Ok(f)
}
