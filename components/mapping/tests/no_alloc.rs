//! Bounded memory: once built, inserting scans into the MLS map, evicting,
//! clearing, integrating into the TSDF and meshing again with grown buffers
//! allocate nothing (the scheduler's accounting allocator, per thread).

mod common;

use nalgebra::Isometry3;
use speleo_mapping::marching_cubes::MeshBuffers;
use speleo_mapping::mls::{MlsMap, MlsParams};
use speleo_mapping::tsdf::{TsdfParams, TsdfVolume};
use speleo_scheduler::accounting::{allocations_in, AccountingAllocator};

#[global_allocator]
static A: AccountingAllocator = AccountingAllocator;

#[test]
fn mls_insertion_eviction_and_clearing_allocate_nothing() {
    let mut rng = common::Rng(9);
    let origins = common::tube_origins(4);
    let scans: Vec<_> = origins
        .iter()
        .map(|o| common::tube_scan(*o, 0.02, &mut rng))
        .collect();
    // Bad points among them: every mark of the insertion pipeline.
    let map_points: Vec<[f64; 3]> = scans[0]
        .iter()
        .enumerate()
        .map(|(k, p)| match k % 1000 {
            1 => [f64::NAN, 0.0, 0.0],
            2 => [1e12, 0.0, 0.0],
            _ => [p[0] as f64, p[1] as f64, p[2] as f64 + 5.0],
        })
        .collect();
    // Small enough to fill up: the full path is exercised too.
    let mut m = MlsMap::new(MlsParams {
        max_cells: 5_000,
        ..MlsParams::default()
    })
    .expect("valid parameters");
    let (stats, n) = allocations_in(|| {
        let mut dropped = 0;
        for (o, s) in origins.iter().zip(&scans) {
            let pose = Isometry3::translation(o[0], o[1], o[2]);
            dropped += m.insert_scan(&pose, s).dropped_map_full;
        }
        let bad = m.insert_points(&map_points);
        m.keep_region([1.0, 0.0], 3.0);
        m.insert_scan(&Isometry3::identity(), &scans[1]);
        let st = m.stats();
        m.clear();
        m.insert_scan(&Isometry3::identity(), &scans[2]);
        (st, dropped, bad)
    });
    assert_eq!(n, 0, "allocations in the MLS map");
    assert!(stats.1 > 0, "the map never filled up");
    assert!(stats.2.non_finite > 0 && stats.2.out_of_range > 0);
    assert!(stats.0.cells > 1000);
}

#[test]
fn tsdf_integration_clearing_and_remeshing_allocate_nothing() {
    let scans = common::tube_scans_map(3, 0.02);
    let mut v = TsdfVolume::new(TsdfParams {
        max_blocks: 4_000,
        ..TsdfParams::default()
    })
    .expect("valid parameters");
    let mut buf = MeshBuffers::new();
    // Grow the mesh buffers once.
    for (o, pts) in &scans {
        v.integrate(*o, pts);
    }
    let first = v.mesh_all(&mut buf);
    let (again, n) = allocations_in(|| {
        v.clear();
        for (o, pts) in &scans {
            v.integrate(*o, pts);
        }
        v.mesh_all(&mut buf)
    });
    assert_eq!(n, 0, "allocations in the TSDF or the meshing");
    assert_eq!(first, again);
    assert!(again.triangles > 10_000);
}
