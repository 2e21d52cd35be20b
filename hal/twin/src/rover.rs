//! Flat-ground skid-steer kinematics of an Asguard-like rover.
//!
//! Each side's wheels follow their commanded speed with a first-order lag and
//! an acceleration limit; body speed is the mean rim speed of the two sides,
//! and the yaw rate is their difference over an effective track widened by
//! the skid factor (skid-steer rovers turn slower than a differential drive
//! with the same geometric track).

pub use speleo_physics::body::WHEELS;
use speleo_physics::body::{BodyState, GRAVITY};
use speleo_physics::quat;

#[derive(Clone, Debug, PartialEq)]
pub struct RoverParams {
    /// Effective rolling radius of a leg-wheel (Asguard's star wheels, ~0.18-0.2 m).
    pub wheel_radius_m: f64,
    /// Distance between left and right wheel centres.
    pub track_width_m: f64,
    /// Effective track / geometric track for turning.
    pub skid_factor: f64,
    /// Speed limit of a drive, rad/s at the wheel.
    pub max_wheel_speed: f64,
    /// Acceleration limit of a drive, rad/s^2.
    pub max_wheel_accel: f64,
    /// First-order time constant of the speed loop.
    pub wheel_time_constant_s: f64,
}

impl Default for RoverParams {
    fn default() -> Self {
        RoverParams {
            wheel_radius_m: 0.19,
            track_width_m: 0.52,
            skid_factor: 1.4,
            max_wheel_speed: 5.0,
            max_wheel_accel: 10.0,
            wheel_time_constant_s: 0.05,
        }
    }
}

#[derive(Clone, Debug)]
pub struct Rover {
    p: RoverParams,
    x: f64,
    y: f64,
    z: f64,
    yaw: f64,
    /// Body-frame forward speed and yaw rate.
    pub speed: f64,
    pub yaw_rate: f64,
    /// Forward acceleration over the last step.
    pub accel: f64,
    /// Wheel speeds (rad/s) and angles (rad).
    pub wheel_speed: [f64; WHEELS],
    pub wheel_angle: [f64; WHEELS],
}

impl Rover {
    pub fn new(p: RoverParams) -> Self {
        Self::at(p, [0.0; 4])
    }

    /// A rover standing at x, y, z (ground height), heading yaw.
    pub fn at(p: RoverParams, start: [f64; 4]) -> Self {
        Rover {
            p,
            x: start[0],
            y: start[1],
            z: start[2],
            yaw: start[3],
            speed: 0.0,
            yaw_rate: 0.0,
            accel: 0.0,
            wheel_speed: [0.0; WHEELS],
            wheel_angle: [0.0; WHEELS],
        }
    }

    pub fn params(&self) -> &RoverParams {
        &self.p
    }

    pub fn yaw(&self) -> f64 {
        self.yaw
    }

    /// Advance by `dt_ns` with the drives aiming at `targets` (rad/s).
    pub fn step(&mut self, dt_ns: u64, targets: &[f64; WHEELS]) {
        let dt = dt_ns as f64 * 1e-9;
        let alpha = dt / (self.p.wheel_time_constant_s + dt);
        for (w, target) in targets.iter().enumerate() {
            let t = target.clamp(-self.p.max_wheel_speed, self.p.max_wheel_speed);
            let dv = (alpha * (t - self.wheel_speed[w]))
                .clamp(-self.p.max_wheel_accel * dt, self.p.max_wheel_accel * dt);
            self.wheel_speed[w] += dv;
            self.wheel_angle[w] += self.wheel_speed[w] * dt;
        }
        let r = self.p.wheel_radius_m;
        let left = 0.5 * (self.wheel_speed[0] + self.wheel_speed[2]) * r;
        let right = 0.5 * (self.wheel_speed[1] + self.wheel_speed[3]) * r;
        let speed = 0.5 * (left + right);
        self.accel = (speed - self.speed) / dt;
        self.speed = speed;
        self.yaw_rate = (right - left) / (self.p.track_width_m * self.p.skid_factor);
        let mid = self.yaw + 0.5 * self.yaw_rate * dt;
        self.x += speed * libm::cos(mid) * dt;
        self.y += speed * libm::sin(mid) * dt;
        self.yaw = wrap_angle(self.yaw + self.yaw_rate * dt);
    }

    /// The true state at `time_ns` (base_link on the ground plane).
    pub fn state(&self, time_ns: u64) -> BodyState {
        let (s, c) = (libm::sin(self.yaw), libm::cos(self.yaw));
        BodyState {
            time_ns,
            position: [self.x, self.y, self.z],
            orientation: quat::from_ypr(self.yaw, 0.0, 0.0),
            velocity: [self.speed * c, self.speed * s, 0.0],
            angular_velocity: [0.0, 0.0, self.yaw_rate],
            specific_force: [self.accel, self.speed * self.yaw_rate, GRAVITY],
            wheel_speed: self.wheel_speed,
            wheel_angle: self.wheel_angle,
            wheel_torque: [0.0; WHEELS],
        }
    }
}

/// Wrap to (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = 2.0 * core::f64::consts::PI;
    let mut a = a % two_pi;
    if a > core::f64::consts::PI {
        a -= two_pi;
    } else if a <= -core::f64::consts::PI {
        a += two_pi;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_wheels_drive_straight_at_rim_speed() {
        let mut r = Rover::new(RoverParams::default());
        for _ in 0..5000 {
            r.step(1_000_000, &[2.0; 4]);
        }
        let t = r.state(0);
        assert!((r.speed - 0.38).abs() < 1e-6, "{}", r.speed);
        assert!(t.position[1].abs() < 1e-12 && t.yaw() == 0.0);
        assert!(
            t.position[0] > 1.6 && t.position[0] < 1.9,
            "{:?}",
            t.position
        );
    }

    #[test]
    fn opposite_wheels_turn_on_the_spot() {
        let mut r = Rover::new(RoverParams::default());
        for _ in 0..1000 {
            r.step(1_000_000, &[-1.0, 1.0, -1.0, 1.0]);
        }
        assert!(r.speed.abs() < 1e-12);
        assert!(r.yaw_rate > 0.5);
    }

    #[test]
    fn commands_are_limited() {
        let mut r = Rover::new(RoverParams::default());
        r.step(1_000_000, &[100.0; 4]);
        assert!(r.wheel_speed[0] <= 0.01 + 1e-12);
        for _ in 0..10_000 {
            r.step(1_000_000, &[100.0; 4]);
        }
        assert!((r.wheel_speed[0] - 5.0).abs() < 1e-9);
    }
}
