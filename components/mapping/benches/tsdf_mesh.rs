//! TSDF integration and meshing speed on one thread: 20 synthetic HDL-32E
//! revolutions (57,600 points each, 1.15 M in all, 2 cm range noise) 1 m
//! apart in the lava tube, 5 cm voxels, truncation 3 voxels, constant
//! weights: the setting in which vdbfusion (OpenVDB, single thread) needs
//! about 0.9 s for 20 HDL-32E cave scans of 1.15 M points.
//!
//! - `integrate_and_mesh`: clear, integrate all 20, mesh everything.
//! - `integrate`: clear and integrate all 20.
//! - `mesh_all`: mesh the integrated volume (buffers already grown).
//!
//! Then the same on revolutions of the HDL-32E twin in the generated lava
//! tube (`twin`: up to 69,440 returns each, in firing order), 20 of them
//! (1.39 M points) and 102 (about 7 M points; vdbfusion needs about 5.3 s
//! for 102 HDL-32E cave scans of 5.9 M points): `twin_20`, `twin_102`.

use criterion::{criterion_group, criterion_main, Criterion};
use speleo_mapping::marching_cubes::MeshBuffers;
use speleo_mapping::tsdf::{TsdfParams, TsdfVolume};
use std::hint::black_box;

#[path = "../tests/common/mod.rs"]
mod common;
mod twin;

/// Integrate `scans` (sensor origin, map-frame points) into a cleared
/// volume and mesh it; prints what came out.
fn integrate_and_mesh_group(c: &mut Criterion, name: &str, scans: &[([f64; 3], Vec<[f64; 3]>)]) {
    let total: usize = scans.iter().map(|s| s.1.len()).sum();
    let mut v = TsdfVolume::new(TsdfParams {
        max_blocks: 1 << 16,
        ..TsdfParams::default()
    })
    .expect("valid parameters");
    let mut buf = MeshBuffers::new();
    let integrate_all = |v: &mut TsdfVolume| {
        v.clear();
        for (o, pts) in scans {
            v.integrate(*o, pts);
        }
    };
    integrate_all(&mut v);
    let st = v.mesh_all(&mut buf);
    let vs = v.stats();
    assert!(!vs.full, "the pool filled up");
    eprintln!(
        "{name}: {} scans, {total} points, {} voxel updates, {} blocks, {} vertices, {} triangles",
        scans.len(),
        vs.voxel_updates,
        vs.blocks,
        st.vertices,
        st.triangles,
    );
    let mut g = c.benchmark_group(name);
    g.sample_size(10);
    g.bench_function("integrate_and_mesh", |b| {
        b.iter(|| {
            integrate_all(&mut v);
            black_box(v.mesh_all(&mut buf))
        })
    });
    g.finish();
}

/// Twin revolutions in the map frame with their sensor origins.
fn twin_scans(n: usize) -> Vec<([f64; 3], Vec<[f64; 3]>)> {
    twin::revolutions(n)
        .into_iter()
        .map(|(pose, scan)| {
            let pts = scan
                .iter()
                .map(|p| {
                    let q = pose * nalgebra::Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                    [q.x, q.y, q.z]
                })
                .collect();
            (pose.translation.vector.into(), pts)
        })
        .collect()
}

fn bench_twin(c: &mut Criterion) {
    let scans = twin_scans(102);
    integrate_and_mesh_group(c, "tsdf_twin_20_scans", &scans[..20]);
    integrate_and_mesh_group(c, "tsdf_twin_102_scans", &scans);
}

fn bench(c: &mut Criterion) {
    let scans = common::tube_scans_map(20, 0.02);
    let total: usize = scans.iter().map(|s| s.1.len()).sum();
    assert_eq!(total, 1_152_000);
    let mut v = TsdfVolume::new(TsdfParams {
        max_blocks: 32_768,
        ..TsdfParams::default()
    })
    .expect("valid parameters");
    let mut buf = MeshBuffers::new();
    let integrate_all = |v: &mut TsdfVolume| {
        v.clear();
        for (o, pts) in &scans {
            v.integrate(*o, pts);
        }
    };
    integrate_all(&mut v);
    let st = v.mesh_all(&mut buf);
    let vs = v.stats();
    eprintln!(
        "tube: {total} points, {} voxel updates, {} blocks ({} MiB), {} vertices, {} triangles, \
         dropped {}",
        vs.voxel_updates,
        vs.blocks,
        vs.memory_bytes >> 20,
        st.vertices,
        st.triangles,
        vs.dropped_updates
    );
    let mut g = c.benchmark_group("tsdf_tube_20_scans");
    g.sample_size(10);
    g.bench_function("integrate_and_mesh", |b| {
        b.iter(|| {
            integrate_all(&mut v);
            black_box(v.mesh_all(&mut buf))
        })
    });
    g.bench_function("integrate", |b| b.iter(|| integrate_all(&mut v)));
    g.bench_function("mesh_all", |b| b.iter(|| black_box(v.mesh_all(&mut buf))));
    g.finish();
}

criterion_group!(benches, bench, bench_twin);
criterion_main!(benches);
