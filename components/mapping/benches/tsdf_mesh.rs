//! TSDF integration and meshing speed on one thread: 20 synthetic HDL-32E
//! revolutions (57,600 points each, 1.15 M in all, 2 cm range noise) 1 m
//! apart in the lava tube, 5 cm voxels, truncation 3 voxels, constant
//! weights: the setting in which vdbfusion (OpenVDB, single thread) needs
//! about 0.9 s for 20 HDL-32E cave scans of 1.15 M points.
//!
//! - `integrate_and_mesh`: clear, integrate all 20, mesh everything.
//! - `integrate`: clear and integrate all 20.
//! - `mesh_all`: mesh the integrated volume (buffers already grown).

use criterion::{criterion_group, criterion_main, Criterion};
use speleo_mapping::marching_cubes::MeshBuffers;
use speleo_mapping::tsdf::{TsdfParams, TsdfVolume};
use std::hint::black_box;

#[path = "../tests/common/mod.rs"]
mod common;

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

criterion_group!(benches, bench);
criterion_main!(benches);
