//! The traversability graph's growth on a realistic map: 40 revolutions of
//! the HDL-32E twin in the generated lava tube (seed 1), 1 m apart, in one
//! multi-level surface map; the graph grown from the first route point in
//! the planner's 30 m window.
//!
//! Printed first: the growth cut into the planner's slices (54 units of
//! 800 work each, `planner.step_units.grow`), each slice timed, median and
//! p99 in microseconds and per unit of work; once with warm caches, once
//! with the caches flushed before each slice, as the executive leaves them
//! (SLAM, the maps and the recorder run between two planner steps).
//! Then, in criterion: a whole growth.

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use speleo_mapping::mls::{MlsMap, MlsParams};
use speleo_traversability::{TravMap, TravParams, Window};

#[path = "../../mapping/benches/twin/mod.rs"]
mod twin;

const REVOLUTIONS: usize = 40;
/// The planner's grow slice: 54 units of 800 work.
const SLICE_WORK: u64 = 54 * 800;
const WINDOW_HALF_M: f64 = 15.0;
/// Larger than the last-level caches here: reading it evicts the map.
const FLUSH_BYTES: usize = 64 << 20;

fn map() -> (MlsMap, [f64; 3]) {
    let revs = twin::revolutions(REVOLUTIONS);
    let mut m = MlsMap::new(MlsParams::default()).expect("valid parameters");
    for (pose, scan) in &revs {
        m.insert_scan(pose, scan);
    }
    // The ground under the first sensor pose (0.54 m above the route).
    let p = revs[0].0.translation.vector;
    (m, [p.x, p.y, p.z - 0.54])
}

fn begin(t: &mut TravMap, m: &MlsMap, start: [f64; 3]) {
    let res = m.params().resolution_m;
    let w = Window::around(start[0], start[1], WINDOW_HALF_M, res);
    t.begin(m, start, Some(w)).expect("ground under the start");
}

/// Slice times of one growth, microseconds, sorted; `flush` reads
/// `FLUSH_BYTES` before each slice.
fn slices(t: &mut TravMap, m: &MlsMap, start: [f64; 3], flush: Option<&mut Vec<u8>>) -> Vec<f64> {
    begin(t, m, start);
    let mut us = Vec::new();
    let mut flush = flush;
    loop {
        if let Some(buf) = flush.as_deref_mut() {
            for b in buf.iter_mut().step_by(64) {
                *b = b.wrapping_add(1);
            }
            black_box(&buf);
        }
        let now = Instant::now();
        let done = t.grow(m, SLICE_WORK);
        us.push(now.elapsed().as_secs_f64() * 1e6);
        if done {
            break;
        }
    }
    us.sort_by(f64::total_cmp);
    us
}

fn quantile(v: &[f64], q: f64) -> f64 {
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn bench(c: &mut Criterion) {
    let (m, start) = map();
    let side = (2.0 * WINDOW_HALF_M / m.params().resolution_m).ceil() as usize + 2;
    let mut t = TravMap::new(TravParams {
        max_window_cells: side * side,
        ..TravParams::default()
    })
    .expect("valid parameters");
    let mut flush = vec![0u8; FLUSH_BYTES];
    for (name, cold) in [("warm", false), ("cold", true)] {
        let mut all = Vec::new();
        for _ in 0..5 {
            all.extend(slices(&mut t, &m, start, cold.then_some(&mut flush)));
        }
        all.sort_by(f64::total_cmp);
        let s = t.stats();
        let work = t.work_done() as f64;
        let per_unit = 1e3 * all.iter().sum::<f64>() / (5.0 * work);
        eprintln!(
            "{name}: {} nodes, {:.0} work a node; slices of {SLICE_WORK} work: \
             median {:.0} us, p99 {:.0} us, max {:.0} us ({} slices); {per_unit:.1} ns a unit",
            s.nodes,
            work / s.nodes as f64,
            quantile(&all, 0.5),
            quantile(&all, 0.99),
            all[all.len() - 1],
            all.len(),
        );
    }
    c.bench_function("graph_growth_30m_window", |b| {
        b.iter(|| {
            begin(&mut t, &m, start);
            while !t.grow(&m, u64::MAX) {}
            black_box(t.stats())
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
