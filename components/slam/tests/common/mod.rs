//! HDL-32E scans cast in a simulated world, for the registration tests.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use speleo_hal::hdl32e::Calibration;
use speleo_twin::lidar::LidarWorld;
use speleo_twin::noise::Noise;

/// Base frame at axle height above the floor; the LiDAR 0.35 m above it.
pub const SENSOR_HEIGHT_M: f64 = 0.19 + 0.35;

/// The sensor's pose at route point `i`, heading for the next one.
pub fn sensor_pose(route: &[[f64; 3]], i: usize) -> Isometry3<f64> {
    let (p, q) = (route[i], route[i + 1]);
    let d = Vector3::new(q[0] - p[0], q[1] - p[1], q[2] - p[2]);
    let yaw = d.y.atan2(d.x);
    let pitch = -d.z.atan2(d.x.hypot(d.y));
    Isometry3::from_parts(
        Translation3::new(p[0], p[1], p[2] + SENSOR_HEIGHT_M),
        UnitQuaternion::from_euler_angles(0.0, pitch, yaw),
    )
}

/// One revolution from `pose` (sensor frame): 32 lasers every 0.2 deg,
/// 2 cm range noise, returns between 1 m and `max_range_m`.
pub fn scan(
    world: &LidarWorld,
    pose: &Isometry3<f64>,
    max_range_m: f64,
    noise: &mut Noise,
) -> Vec<[f64; 3]> {
    let cal = Calibration::nominal();
    let o = pose.translation.vector;
    let mut out = Vec::with_capacity(57_600);
    for a in 0..1800 {
        let az = (a as f64 * 0.2).to_radians();
        for laser in &cal.lasers {
            let el = laser.vert_deg.to_radians();
            let local = Vector3::new(el.cos() * az.cos(), -el.cos() * az.sin(), el.sin());
            let dir = pose.rotation * local;
            let Some((r, _, _)) = world.cast([o.x, o.y, o.z], [dir.x, dir.y, dir.z], 70.0) else {
                continue;
            };
            let r = r + 0.02 * noise.gaussian();
            if r > 1.0 && r < max_range_m {
                out.push((local * r).into());
            }
        }
    }
    out
}
