//! MLS insertion speed on one thread, on realistic revolutions of the
//! HDL-32E twin in the generated lava tube (`twin`). Firing order puts
//! consecutive points in far-apart cells. Budget: 5 ms per revolution.
//!
//! - First, printed: each revolution timed on its own, inserted in turn
//!   into a map holding the previous ones (median and maximum over
//!   revolutions and rounds).
//! - `steady`: one revolution into a map holding the previous ones
//!   (mostly known cells, as while driving); the map is refilled, untimed,
//!   when the revolutions run out.
//! - `fresh_map`: one revolution into an empty map (every cell new).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use nalgebra::Isometry3;
use speleo_mapping::mls::{MlsMap, MlsParams};

mod twin;

/// Revolutions cast, 1 m apart.
const REVOLUTIONS: usize = 40;
/// Revolutions already in the map before the timed ones.
const WARM_UP: usize = 10;
/// Times each revolution from `WARM_UP` on, inserted in turn into a map
/// holding the previous ones, over a few rounds: (median, maximum) in ms.
fn per_revolution(revs: &[(Isometry3<f64>, Vec<[f32; 3]>)], rounds: usize) -> (f64, f64) {
    let mut m = MlsMap::new(MlsParams::default()).expect("valid parameters");
    let mut ms = Vec::with_capacity(rounds * REVOLUTIONS);
    for _ in 0..rounds {
        m.clear();
        for (i, (pose, scan)) in revs.iter().enumerate() {
            let t = Instant::now();
            black_box(m.insert_scan(pose, scan));
            if i >= WARM_UP {
                ms.push(t.elapsed().as_secs_f64() * 1e3);
            }
        }
    }
    ms.sort_by(f64::total_cmp);
    (ms[ms.len() / 2], ms[ms.len() - 1])
}

fn bench(c: &mut Criterion) {
    let revs = twin::revolutions(REVOLUTIONS);
    let points: usize = revs.iter().map(|r| r.1.len()).sum();
    let (median, max) = per_revolution(&revs, 5);
    eprintln!(
        "{REVOLUTIONS} revolutions of {} points on average; each timed into a map holding \
         the previous ones: median {median:.2} ms, max {max:.2} ms",
        points / REVOLUTIONS
    );
    let params = MlsParams::default();
    let mut g = c.benchmark_group("mls_insert_twin_revolution");
    let mut m = MlsMap::new(params.clone()).expect("valid parameters");
    let mut next = REVOLUTIONS;
    g.bench_function("steady", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                if next == REVOLUTIONS {
                    m.clear();
                    for (pose, scan) in &revs[..WARM_UP] {
                        m.insert_scan(pose, scan);
                    }
                    next = WARM_UP;
                }
                let (pose, scan) = &revs[next];
                let t = Instant::now();
                black_box(m.insert_scan(pose, scan));
                total += t.elapsed();
                next += 1;
            }
            total
        })
    });
    let (pose, scan) = &revs[WARM_UP];
    g.bench_function("fresh_map", |b| {
        b.iter_batched_ref(
            || MlsMap::new(params.clone()).expect("valid parameters"),
            |m| black_box(m.insert_scan(pose, scan)),
            BatchSize::PerIteration,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
