//! The simulated HDL-32E in the generated lava tube: one simulated second
//! (10 revolutions, ~1,808 packets) cast, encoded and queued, with the
//! sensor driving along the tube, its rays cast on one thread and on two.
//! Real-time factor = 1 s / measured time. Then the rays alone, through the
//! twin's BVH and through parry's.

use std::sync::Arc;

use criterion::{criterion_group, criterion_main, Criterion};
use speleo_hal::hdl32e::Calibration;
use speleo_twin::lidar::{LidarParams, LidarTwin, LidarWorld, SensorPose};
use speleo_twin::world::World;

fn bench(c: &mut Criterion) {
    let w = World::build("lava-tube", 1).expect("tube");
    let lw = Arc::new(LidarWorld::new(&w.mesh).expect("mesh"));
    let mut g = c.benchmark_group("lidar_twin");
    g.sample_size(10);
    for threads in [1, 2] {
        g.bench_function(
            format!(
                "lava_tube_{}_triangles_one_second_{threads}_threads",
                w.mesh.triangle_count()
            ),
            |b| {
                b.iter(|| {
                    let p = LidarParams {
                        cast_threads: threads,
                        ..LidarParams::default()
                    };
                    let mut l = LidarTwin::new(p, Calibration::nominal(), lw.clone(), 1);
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
                    // 1 ms physics steps, rays cast once a 10 ms frame, as in
                    // the simulated hardware.
                    for k in 0..1000u64 {
                        let (a, b) = (k as f64 * 1e-3, (k + 1) as f64 * 1e-3);
                        l.queue(k * 1_000_000, (k + 1) * 1_000_000, &pose(a), &pose(b));
                        if k % 10 == 9 {
                            l.flush();
                            while l.outbox_len_pop() {
                                packets += 1;
                            }
                        }
                    }
                    std::hint::black_box(packets)
                })
            },
        );
    }
    g.finish();

    // The rays alone: one revolution's 57,600 directions (32 lasers at the
    // HDL-32E's elevations, 0.2 deg apart) from 0.7 m above the tube's
    // start, through the CWBVH the twin casts against and through parry's
    // BVH of the same mesh.
    let o = [w.start[0], w.start[1], w.start[2] + 0.7];
    let dirs: Vec<[f64; 3]> = (0..32)
        .flat_map(|l| {
            let el = (-30.67f64 + 4.0 / 3.0 * l as f64).to_radians();
            (0..1800).map(move |a| {
                let az = (a as f64 * 0.2).to_radians();
                [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()]
            })
        })
        .collect();
    let mut g = c.benchmark_group("ray_cast_revolution");
    g.sample_size(20);
    g.bench_function("obvhs_cwbvh", |b| {
        b.iter(|| {
            dirs.iter()
                .filter_map(|d| lw.cast_hit(o, *d, 70.0))
                .map(|h| h.0)
                .sum::<f64>()
        })
    });
    g.bench_function("parry_bvh", |b| {
        b.iter(|| {
            dirs.iter()
                .filter_map(|d| lw.cast_parry(o, *d, 70.0))
                .map(|h| h.0)
                .sum::<f64>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
