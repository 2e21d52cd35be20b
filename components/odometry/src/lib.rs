//! Wheel and IMU odometry for a skid-steer rover.
//!
//! Skid-steer wheels slip whenever the rover turns, so the heading comes from
//! the IMU's rate of turn, integrated as a full 3D rotation; the wheels only
//! give the distance travelled (mean encoder travel of the four wheels). Roll
//! and pitch are taken from the first IMU orientation, which the device
//! references to gravity. Each step moves the pose by the distance along the
//! body's x axis at the mid-step orientation.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

#[derive(Clone, Debug, PartialEq)]
pub struct OdometryParams {
    pub wheel_radius_m: f64,
    /// Encoder increments per wheel revolution.
    pub counts_per_rev: f64,
    /// A wheel step longer than this (m) is an encoder glitch and is ignored.
    pub max_step_m: f64,
}

/// One IMU sample as the odometry needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuInput {
    pub time_ns: u64,
    /// Body rate of turn, rad/s.
    pub gyro: [f64; 3],
    /// Device orientation (w, x, y, z), gravity referenced.
    pub orientation: [f64; 4],
}

#[derive(Clone, Debug)]
pub struct Odometry {
    p: OdometryParams,
    pose: Isometry3<f64>,
    last_counts: Option<[i32; 4]>,
    last_imu_ns: Option<u64>,
    distance_m: f64,
    /// Wheel steps rejected as glitches.
    pub rejected_steps: u64,
}

impl Odometry {
    pub fn new(p: OdometryParams) -> Self {
        Odometry {
            p,
            pose: Isometry3::identity(),
            last_counts: None,
            last_imu_ns: None,
            distance_m: 0.0,
            rejected_steps: 0,
        }
    }

    pub fn pose(&self) -> &Isometry3<f64> {
        &self.pose
    }

    /// Distance travelled since start, m.
    pub fn distance_m(&self) -> f64 {
        self.distance_m
    }

    /// Integrate one IMU sample (rotation only).
    pub fn imu(&mut self, s: &ImuInput) {
        let Some(last) = self.last_imu_ns.replace(s.time_ns) else {
            // Start level with the device's roll and pitch, heading zero.
            let [w, x, y, z] = s.orientation;
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
            let (roll, pitch, _) = q.euler_angles();
            self.pose.rotation = UnitQuaternion::from_euler_angles(roll, pitch, 0.0);
            return;
        };
        let dt = s.time_ns.saturating_sub(last) as f64 * 1e-9;
        if dt <= 0.0 || dt > 1.0 {
            // A gap (or a repeated sample): do not integrate over it.
            return;
        }
        let w = Vector3::from(s.gyro) * dt;
        self.pose.rotation = UnitQuaternion::new_normalize(
            (self.pose.rotation * UnitQuaternion::from_scaled_axis(w)).into_inner(),
        );
    }

    /// Integrate new encoder positions (front left, front right, rear left,
    /// rear right). Returns the distance of this step.
    pub fn wheels(&mut self, counts: [i32; 4]) -> f64 {
        let Some(last) = self.last_counts.replace(counts) else {
            return 0.0;
        };
        let per_count = 2.0 * core::f64::consts::PI * self.p.wheel_radius_m / self.p.counts_per_rev;
        let mut sum = 0.0;
        for i in 0..4 {
            // Wrapping difference: the 32-bit position registers roll over.
            sum += counts[i].wrapping_sub(last[i]) as f64 * per_count;
        }
        let d = sum / 4.0;
        if d.abs() > self.p.max_step_m {
            self.rejected_steps += 1;
            return 0.0;
        }
        let step = self.pose.rotation * Vector3::new(d, 0.0, 0.0);
        self.pose.translation = Translation3::from(self.pose.translation.vector + step);
        self.distance_m += d.abs();
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> OdometryParams {
        OdometryParams {
            wheel_radius_m: 0.2,
            counts_per_rev: 1000.0,
            max_step_m: 2.0,
        }
    }

    fn imu(t_ms: u64, yaw_rate: f64) -> ImuInput {
        ImuInput {
            time_ns: t_ms * 1_000_000,
            gyro: [0.0, 0.0, yaw_rate],
            orientation: [1.0, 0.0, 0.0, 0.0],
        }
    }

    #[test]
    fn straight_line() {
        let mut o = Odometry::new(params());
        o.wheels([0; 4]);
        // One revolution = 2 pi 0.2 m.
        o.wheels([1000; 4]);
        let t = o.pose().translation.vector;
        assert!((t.x - 2.0 * core::f64::consts::PI * 0.2).abs() < 1e-12);
        assert!(t.y.abs() < 1e-12);
    }

    #[test]
    fn quarter_turn_then_forward_goes_left() {
        let mut o = Odometry::new(params());
        o.imu(&imu(0, 0.0));
        for k in 1..=100 {
            o.imu(&imu(k * 10, core::f64::consts::FRAC_PI_2));
        }
        o.wheels([0; 4]);
        o.wheels([1000; 4]);
        let t = o.pose().translation.vector;
        assert!(t.x.abs() < 1e-9, "{t}");
        assert!((t.y - 1.2566370614359172).abs() < 1e-9, "{t}");
    }

    #[test]
    fn encoder_wrap_and_glitches() {
        let mut o = Odometry::new(params());
        o.wheels([i32::MAX - 5; 4]);
        let d = o.wheels([i32::MIN + 4; 4]);
        assert!((d - 10.0 * 2.0 * core::f64::consts::PI * 0.2 / 1000.0).abs() < 1e-12);
        assert_eq!(o.wheels([10_000; 4]), 0.0);
        assert_eq!(o.rejected_steps, 1);
    }
}
