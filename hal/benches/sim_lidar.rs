//! The simulated HDL-32E in the generated lava tube: one simulated second
//! (10 revolutions, ~1,808 packets) cast, encoded and queued, with the
//! sensor driving along the tube. Real-time factor = 1 s / measured time.

use std::sync::Arc;

use criterion::{criterion_group, criterion_main, Criterion};
use speleo_hal::hdl32e::Calibration;
use speleo_hal::sim::lidar::{LidarParams, LidarWorld, SensorPose, SimLidar};
use speleo_hal::world::World;

fn bench(c: &mut Criterion) {
    let w = World::build("lava-tube", 1).expect("tube");
    let lw = Arc::new(LidarWorld::new(&w.mesh).expect("mesh"));
    let mut g = c.benchmark_group("sim_lidar");
    g.sample_size(10);
    g.bench_function(
        format!("lava_tube_{}_triangles_one_second", w.mesh.triangle_count()),
        |b| {
            b.iter(|| {
                let mut l = SimLidar::new(
                    LidarParams::default(),
                    Calibration::nominal(),
                    lw.clone(),
                    1,
                );
                let (x0, y0, z0, yaw) = (w.start[0], w.start[1], w.start[2] + 0.7, w.start[3]);
                let pose = |t: f64| {
                    SensorPose::from_ypr(
                        [x0 + 0.4 * t * yaw.cos(), y0 + 0.4 * t * yaw.sin(), z0],
                        yaw,
                        0.0,
                        0.0,
                    )
                };
                let mut packets = 0;
                for k in 0..1000u64 {
                    let (a, b) = (k as f64 * 1e-3, (k + 1) as f64 * 1e-3);
                    l.advance(k * 1_000_000, (k + 1) * 1_000_000, &pose(a), &pose(b));
                    while l.outbox_len_pop() {
                        packets += 1;
                    }
                }
                std::hint::black_box(packets)
            })
        },
    );
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
