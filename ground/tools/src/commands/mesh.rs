//! `speleo mesh`: scans or a recording's keyframes meshed through a TSDF.

use std::path::Path;
use std::process::ExitCode;

use crate::args::MeshArgs;
use crate::Error;

/// The most blocks `mesh` takes: 4 GiB of pool.
const MESH_MAX_BLOCKS: usize = 1 << 20;

/// `speleo mesh`: from PLY scans with KITTI poses, or from a recording's
/// keyframes (the recording is run through the drivers and SLAM again).
pub fn mesh(a: MeshArgs, progress: bool) -> Result<ExitCode, Error> {
    // The pool is taken whole before the first scan (4 KiB a block).
    if !(1..=MESH_MAX_BLOCKS).contains(&a.max_blocks) {
        return Err(format!(
            "--max-blocks {}: must be 1..={MESH_MAX_BLOCKS} (4 KiB a block, {} GiB at most)",
            a.max_blocks,
            (MESH_MAX_BLOCKS * 4096) >> 30
        )
        .into());
    }
    let params = speleo_mapping::tsdf::TsdfParams {
        voxel_size_m: a.voxel,
        truncation_voxels: a.trunc,
        max_blocks: a.max_blocks,
        ..speleo_mapping::tsdf::TsdfParams::default()
    };
    let report = match (&a.scans, &a.poses, &a.record) {
        (Some(dir), Some(poses), None) => crate::mesh::from_scans(dir, poses, params, &a.out)?,
        (None, None, Some(log)) => mesh_recording(log, params, &a.out, progress)?,
        _ => return Err("give --scans DIR --poses POSES.txt, or --record LOG.mcap".into()),
    };
    println!(
        "{} scans, {} points: {} blocks, {} vertices, {} triangles; integrate {:.3} s, mesh {:.3} s, total {:.3} s{}",
        report.scans,
        report.points,
        report.tsdf_blocks,
        report.vertices,
        report.triangles,
        report.integrate_s,
        report.mesh_s,
        report.total_s,
        if report.tsdf_full { " (the TSDF filled up: raise --max-blocks)" } else { "" }
    );
    if let Some(p) = &a.report {
        speleo_firmware::report::write_json(p, &report)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// A recording run through the drivers and SLAM again, its keyframes meshed.
fn mesh_recording(
    log: &Path,
    params: speleo_mapping::tsdf::TsdfParams,
    out: &Path,
    progress: bool,
) -> Result<crate::mesh::MeshReport, Error> {
    let result = speleo_firmware::commands::replay_for_maps(log, progress)?;
    let Some(maps) = &result.maps else {
        return Err(format!(
            "{}: SLAM is off in the recorded configuration",
            log.display()
        )
        .into());
    };
    if maps.keyframes.ready() == 0 {
        return Err(format!("{}: SLAM made no keyframe (no LiDAR?)", log.display()).into());
    }
    let points: u64 = (0..maps.keyframes.ready())
        .map(|k| maps.keyframes.cloud(k).len() as u64)
        .sum();
    let m = speleo_firmware::maps_output::mesh_keyframes(params.clone(), maps)?;
    speleo_firmware::maps_output::write_mesh(out, &m.mesh)?;
    Ok(crate::mesh::MeshReport::new(
        log.display().to_string(),
        maps.keyframes.ready(),
        points,
        &params,
        &m,
    ))
}
