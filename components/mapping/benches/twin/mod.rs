//! Realistic HDL-32E revolutions for the benchmarks: the LiDAR twin of
//! `speleo-twin` (nominal elevations, 32 lasers a firing, a firing every
//! 46.08 us at 10 Hz: 2,170 firings, up to 69,440 returns, in firing order)
//! cast in the generated lava tube (seed 1) from poses 1 m apart along its
//! route, the sensor 0.54 m above the route point and heading for the next
//! one, 2 cm range noise, returns to 70 m.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use speleo_hal::hdl32e::{Calibration, BLOCK_PERIOD_NS, LASERS, LASER_PERIOD_NS};
use speleo_twin::lidar::LidarWorld;
use speleo_twin::noise::Noise;
use speleo_twin::world::lava_tube::{generate, LavaTubeParams};

/// Rotation rate (Hz).
const RATE_HZ: f64 = 10.0;
/// Sensor above the route point (axle height 0.19 m, LiDAR 0.35 m above).
const SENSOR_HEIGHT_M: f64 = 0.54;
const MAX_RANGE_M: f64 = 70.0;
const RANGE_NOISE_M: f64 = 0.02;

/// The sensor's pose at route point `i`, heading for the next one.
fn sensor_pose(route: &[[f64; 3]], i: usize) -> Isometry3<f64> {
    let (p, q) = (route[i], route[i + 1]);
    let d = Vector3::new(q[0] - p[0], q[1] - p[1], q[2] - p[2]);
    let yaw = d.y.atan2(d.x);
    let pitch = -d.z.atan2(d.x.hypot(d.y));
    Isometry3::from_parts(
        Translation3::new(p[0], p[1], p[2] + SENSOR_HEIGHT_M),
        UnitQuaternion::from_euler_angles(0.0, pitch, yaw),
    )
}

/// One revolution from `pose`, in the sensor frame and firing order.
fn revolution(world: &LidarWorld, pose: &Isometry3<f64>, noise: &mut Noise) -> Vec<[f32; 3]> {
    let cal = Calibration::nominal();
    let period_s = BLOCK_PERIOD_NS * 1e-9;
    let firings = (1.0 / (RATE_HZ * period_s)) as usize;
    // Azimuth advance per firing, and per laser within one (radians).
    let step = std::f64::consts::TAU * RATE_HZ * period_s;
    let laser_step = step * LASER_PERIOD_NS / BLOCK_PERIOD_NS;
    let o = pose.translation.vector;
    let mut out = Vec::with_capacity(firings * LASERS);
    for f in 0..firings {
        for (l, laser) in cal.lasers.iter().enumerate() {
            let az = f as f64 * step + l as f64 * laser_step;
            let el = laser.vert_deg.to_radians();
            // Azimuth clockwise from x, as the sensor counts.
            let local = Vector3::new(el.cos() * az.cos(), -el.cos() * az.sin(), el.sin());
            let dir = pose.rotation * local;
            let Some((r, _, _)) = world.cast([o.x, o.y, o.z], [dir.x, dir.y, dir.z], MAX_RANGE_M)
            else {
                continue;
            };
            let r = r + RANGE_NOISE_M * noise.gaussian();
            if r > 0.0 {
                let p = local * r;
                out.push([p.x as f32, p.y as f32, p.z as f32]);
            }
        }
    }
    out
}

/// `n` revolutions, each with its sensor pose (map <- sensor), the points
/// in the sensor frame.
pub fn revolutions(n: usize) -> Vec<(Isometry3<f64>, Vec<[f32; 3]>)> {
    let tube = generate(1, &LavaTubeParams::default());
    let Ok(world) = LidarWorld::new(&tube.mesh) else {
        panic!("the tube is not a ray-castable mesh");
    };
    assert!(tube.route.len() > n, "route too short");
    let mut noise = Noise::new(7, 1);
    (0..n)
        .map(|i| {
            let pose = sensor_pose(&tube.route, i);
            let scan = revolution(&world, &pose, &mut noise);
            (pose, scan)
        })
        .collect()
}
