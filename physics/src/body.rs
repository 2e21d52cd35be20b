//! The rover's true motion, as every sensor twin sees it.
//!
//! Both rover models (flat-ground kinematics and the rapier3d physics rover)
//! produce one `BodyState` per step; the IMU, the drives' encoders and the
//! LiDAR read only this, so they behave the same on either model.

use crate::quat::{self, Quat};

/// Wheel order: front left, front right, rear left, rear right (drive nodes 1..=4).
pub const WHEELS: usize = 4;

/// Standard gravity, m/s^2.
pub const GRAVITY: f64 = 9.81;

/// The true state of base_link (the chassis frame: x forward, y left, z up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyState {
    pub time_ns: u64,
    /// Position in the world, m.
    pub position: [f64; 3],
    /// base_link to world.
    pub orientation: Quat,
    /// World-frame velocity, m/s.
    pub velocity: [f64; 3],
    /// Angular velocity in base_link, rad/s.
    pub angular_velocity: [f64; 3],
    /// What an accelerometer at base_link reads: acceleration minus gravity,
    /// in base_link (at rest on level ground: (0, 0, +g)).
    pub specific_force: [f64; 3],
    /// Wheel speeds relative to the chassis, rad/s, and their angles, rad.
    pub wheel_speed: [f64; WHEELS],
    pub wheel_angle: [f64; WHEELS],
    /// Torque each drive applies to its wheel, N m, positive turning it
    /// forward (what the drives report as torque actual, 0x6077). The
    /// flat-ground kinematic model has no forces: 0 there.
    pub wheel_torque: [f64; WHEELS],
}

impl Default for BodyState {
    fn default() -> Self {
        BodyState {
            time_ns: 0,
            position: [0.0; 3],
            orientation: quat::IDENTITY,
            velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
            specific_force: [0.0, 0.0, GRAVITY],
            wheel_speed: [0.0; WHEELS],
            wheel_angle: [0.0; WHEELS],
            wheel_torque: [0.0; WHEELS],
        }
    }
}

impl BodyState {
    /// Heading, pitch and roll (Z-Y-X).
    pub fn ypr(&self) -> (f64, f64, f64) {
        quat::to_ypr(&self.orientation)
    }

    pub fn yaw(&self) -> f64 {
        self.ypr().0
    }

    /// Speed along the chassis' forward axis, m/s.
    pub fn forward_speed(&self) -> f64 {
        quat::rotate_inv(&self.orientation, self.velocity)[0]
    }

    /// A point given in base_link, in the world.
    pub fn to_world(&self, p: [f64; 3]) -> [f64; 3] {
        let r = quat::rotate(&self.orientation, p);
        [
            self.position[0] + r[0],
            self.position[1] + r[1],
            self.position[2] + r[2],
        ]
    }
}
