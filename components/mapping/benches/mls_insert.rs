//! MLS insertion speed on one thread: one synthetic HDL-32E revolution
//! (57,600 points, 2 cm range noise) in the lava tube (radius 2 m, flat
//! floor), moved by a pose. Budget: 5 ms per revolution.
//!
//! - `fresh_map`: into an empty map (every cell new).
//! - `steady`: into a map that already holds the previous revolutions of
//!   the tube (mostly known cells, as while driving).

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use speleo_mapping::mls::{MlsMap, MlsParams};
use std::hint::black_box;

#[path = "../tests/common/mod.rs"]
mod common;

fn bench(c: &mut Criterion) {
    let mut rng = common::Rng(17);
    let origins = common::tube_origins(6);
    let scans: Vec<Vec<[f32; 3]>> = origins
        .iter()
        .map(|o| common::tube_scan(*o, 0.02, &mut rng))
        .collect();
    let pose = |o: [f64; 3]| {
        Isometry3::from_parts(
            Translation3::new(o[0], o[1], o[2]),
            UnitQuaternion::from_euler_angles(0.01, 0.02, 0.0),
        )
    };
    let last = scans.len() - 1;
    assert_eq!(scans[last].len(), 57_600);
    let params = MlsParams::default();
    let mut g = c.benchmark_group("mls_insert_revolution");
    g.bench_function("fresh_map", |b| {
        b.iter_batched_ref(
            || MlsMap::new(params.clone()).expect("valid parameters"),
            |m| black_box(m.insert_scan(&pose(origins[last]), &scans[last])),
            BatchSize::PerIteration,
        )
    });
    let mut m = MlsMap::new(params.clone()).expect("valid parameters");
    for (o, s) in origins.iter().zip(&scans).take(last) {
        m.insert_scan(&pose(*o), s);
    }
    g.bench_function("steady", |b| {
        b.iter(|| black_box(m.insert_scan(&pose(origins[last]), &scans[last])))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
