//! One 10 ms physics step of the rover (the internal simulator's step)
//! standing yawed 29 degrees across a 15-degree slope of 5 cm triangles (a
//! TSDF mesh's density), driven back and forth on it (a second each way): the case where the chassis
//! box's axis-aligned bounding box reaches into hundreds of the ground's
//! triangles. With the chassis's first test (`ChassisContacts`, the
//! default) and, as the reference in the same run, parry's own narrow phase.

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use speleo_physics::rover::{PhysicsParams, PhysicsRover};
use speleo_physics::terrain::{Material, Mesh};

/// A plane rising 15 degrees along x, 3 m square, of 5 cm right triangles.
fn slope() -> Mesh {
    let (n, cell) = (60u32, 0.05);
    let rise = 15f64.to_radians().tan();
    let mut m = Mesh::default();
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (-1.5 + i as f64 * cell, -1.5 + j as f64 * cell);
            m.vertices.push([x as f32, y as f32, (x * rise) as f32]);
        }
    }
    for i in 0..n {
        for j in 0..n {
            let v = i * (n + 1) + j;
            m.triangles.push([v, v + n + 1, v + n + 2]);
            m.triangles.push([v, v + n + 2, v + 1]);
            m.materials.extend([Material::Rock; 2]);
        }
    }
    m
}

/// The rover settled on its legs on the slope, its narrow phase parry's
/// own when `parry_only`.
fn settled(ground: &Mesh, parry_only: bool) -> PhysicsRover {
    let mut r = PhysicsRover::new(
        &PhysicsParams::default(),
        ground,
        [0.0, 0.0, 0.08, 0.5],
        0.01,
    )
    .expect("rover");
    if parry_only {
        r.use_parry_narrow_phase();
    }
    for k in 0..100u64 {
        r.step(k * 10_000_000, &[0.0; 4]);
    }
    r
}

/// Steps per rover: it drives a second each way, then a fresh one is
/// settled (untimed), so it never creeps off the slope's edge.
const STEPS_PER_ROVER: u64 = 400;

fn bench(c: &mut Criterion) {
    let ground = slope();
    let mut g = c.benchmark_group("physics_step");
    for (name, parry_only) in [("chassis_first_test", false), ("parry_narrow_phase", true)] {
        g.bench_function(format!("slope_15deg_yawed_{name}"), |b| {
            b.iter_custom(|iters| {
                let mut spent = Duration::ZERO;
                let mut done = 0;
                while done < iters {
                    let mut r = settled(&ground, parry_only);
                    let n = (iters - done).min(STEPS_PER_ROVER);
                    let t0 = Instant::now();
                    for k in 100..100 + n {
                        let w = if (k / 100) % 2 == 0 { 1.0 } else { -1.0 };
                        r.step(k * 10_000_000, &[w; 4]);
                    }
                    spent += t0.elapsed();
                    done += n;
                }
                spent
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
