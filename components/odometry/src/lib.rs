//! Wheel and IMU odometry for a skid-steer rover, slip-aware, and a pose
//! history for deskewing.
//!
//! - **Attitude.** The IMU's rate of turn is integrated as a full 3D
//!   rotation. Roll and pitch are pulled towards the device's
//!   gravity-referenced roll and pitch by a complementary filter (time
//!   constant [`OdometryParams::attitude_time_constant_s`]); heading comes
//!   from the integrated rate of turn only (the device's own heading drifts),
//!   zero at start. The IMU frame is taken as the body frame.
//! - **Travel.** Each wheel step compares the four wheels' travel, each
//!   turned into a forward speed estimate with the gyro's yaw (a skid-steer
//!   side moves at v -+ yaw rate * track * chi / 2). Wheels that disagree
//!   with the consensus (the median) are slipping, spinning, stuck or
//!   glitching and are left out; when there is no consensus the
//!   smallest-magnitude wheels are trusted. Without slip the forward travel
//!   is the mean of the four wheels (which does not depend on chi).
//! - **Pose.** Each step moves the pose by the travel along the body's x axis
//!   at the mid-step orientation, in 3D: climbing a slope gains height.
//!
//! Deterministic (the trigonometry is `libm`'s), allocation-free after
//! construction, and no input panics it: non-finite or implausible IMU
//! samples, repeated or backwards times, encoder roll-over and glitches are
//! counted in [`OdometryCounters`].

mod history;
pub mod rot;

pub use history::PoseHistory;

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};

#[derive(Clone, Debug, PartialEq)]
pub struct OdometryParams {
    /// Rolling radius of the wheels, m.
    pub wheel_radius_m: f64,
    /// Encoder increments per wheel revolution.
    pub counts_per_rev: f64,
    /// A wheel's step longer than this (m) is an encoder glitch and that
    /// wheel is ignored for the step.
    pub max_step_m: f64,
    /// Left to right wheel centres, m.
    pub track_width_m: f64,
    /// Skid-steer factor chi: yaw rate = (right - left) / (track * chi).
    pub skid_factor: f64,
    /// Time constant of the pull of roll and pitch towards the device's
    /// gravity-referenced roll and pitch, s (0: take the device's directly).
    pub attitude_time_constant_s: f64,
    /// A wheel disagrees with the consensus when its speed estimate differs
    /// by more than two encoder counts plus this (m/s, times the step) ...
    pub slip_speed_tolerance: f64,
    /// ... plus this fraction of the consensus speed ...
    pub slip_relative_tolerance: f64,
    /// ... plus this fraction of the gyro's yaw share of the side speeds
    /// (how uncertain `skid_factor` is).
    pub skid_factor_uncertainty: f64,
    /// IMU samples further apart than this are not integrated across; roll
    /// and pitch are then reset to the device's, s.
    pub max_imu_gap_s: f64,
    /// A rate of turn above this (rad/s) is a glitch.
    pub max_rate: f64,
}

impl Default for OdometryParams {
    /// The Asguard-like rover: 0.19 m leg-wheels, 0.52 m track, chi 1.4,
    /// 16384-count encoders.
    fn default() -> Self {
        OdometryParams {
            wheel_radius_m: 0.19,
            counts_per_rev: 16384.0,
            max_step_m: 1.0,
            track_width_m: 0.52,
            skid_factor: 1.4,
            attitude_time_constant_s: 1.0,
            slip_speed_tolerance: 0.05,
            slip_relative_tolerance: 0.15,
            skid_factor_uncertainty: 0.5,
            max_imu_gap_s: 0.5,
            max_rate: 35.0,
        }
    }
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

/// What the odometry counted. Wheels in the order front left, front right,
/// rear left, rear right.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OdometryCounters {
    pub imu_samples: u64,
    /// Samples with a non-finite or implausible rate of turn or orientation
    /// (the good half of the sample is still used).
    pub imu_rejected: u64,
    /// Samples not integrated: repeated or backwards time, or a gap longer
    /// than `max_imu_gap_s`.
    pub imu_gaps: u64,
    pub wheel_steps: u64,
    /// Whole wheel steps ignored: every wheel glitched.
    pub rejected_steps: u64,
    /// Per wheel: steps longer than `max_step_m` (or not finite).
    pub wheel_glitches: [u64; 4],
    /// Steps in which at least one wheel was left out as slipping.
    pub slip_steps: u64,
    /// Runs of consecutive slip steps.
    pub slip_events: u64,
    /// Per wheel: steps it was left out as slipping.
    pub wheel_slips: [u64; 4],
    /// Slip steps without a consensus (the smallest-magnitude wheels used).
    pub ambiguous_steps: u64,
    /// Steps in which the wheels' yaw, (right - left) / (track * chi),
    /// disagreed with the gyro's beyond the tolerance.
    pub yaw_mismatches: u64,
}

const LEFT: [bool; 4] = [true, false, true, false];

#[derive(Clone, Debug)]
pub struct Odometry {
    p: OdometryParams,
    pose: Isometry3<f64>,
    /// Roll and pitch have been set from the device at least once.
    attitude_ready: bool,
    last_imu_ns: Option<u64>,
    last_counts: Option<[i32; 4]>,
    last_wheel_ns: u64,
    /// Attitude at the last wheel step (for the mid-step orientation).
    attitude_at_wheels: UnitQuaternion<f64>,
    /// Gyro rotation about body z since the last wheel step, rad, and the
    /// number of samples it holds.
    gyro_yaw: f64,
    gyro_samples: u32,
    /// The last sample's rate of turn (body, rad/s; zero if rejected) and
    /// the velocity of the last wheel step (odometry frame, m/s): `pose_at`
    /// carries the pose on with them.
    last_gyro: Vector3<f64>,
    last_velocity: Vector3<f64>,
    slipping: bool,
    distance_m: f64,
    counters: OdometryCounters,
}

/// The device orientation if it is a plausible unit quaternion.
fn device_attitude(o: &[f64; 4]) -> Option<UnitQuaternion<f64>> {
    if !o.iter().all(|v| v.is_finite()) {
        return None;
    }
    let q = Quaternion::new(o[0], o[1], o[2], o[3]);
    let n = libm::sqrt(q.coords.dot(&q.coords));
    ((0.9..=1.1).contains(&n)).then(|| UnitQuaternion::new_normalize(q))
}

/// Longest a pose is carried on past its last measurement (two IMU periods
/// at 100 Hz): beyond that a sensor is late, and guessing does more harm.
pub const MAX_EXTRAPOLATION_NS: u64 = 20_000_000;

/// Largest |pitch| at which roll and yaw are still well apart, rad.
const MAX_CORRECTED_PITCH: f64 = 1.4;

impl Odometry {
    pub fn new(p: OdometryParams) -> Self {
        Odometry {
            p,
            pose: Isometry3::identity(),
            attitude_ready: false,
            last_imu_ns: None,
            last_counts: None,
            last_wheel_ns: 0,
            attitude_at_wheels: UnitQuaternion::identity(),
            gyro_yaw: 0.0,
            gyro_samples: 0,
            last_gyro: Vector3::zeros(),
            last_velocity: Vector3::zeros(),
            slipping: false,
            distance_m: 0.0,
            counters: OdometryCounters::default(),
        }
    }

    pub fn params(&self) -> &OdometryParams {
        &self.p
    }

    /// Pose of the body in the odometry frame (level, heading zero and
    /// position zero at start).
    pub fn pose(&self) -> &Isometry3<f64> {
        &self.pose
    }

    /// The pose carried on to `time_ns` from the last IMU sample (by its rate
    /// of turn) and the last wheel step (by its velocity); not carried from
    /// a measurement older than `MAX_EXTRAPOLATION_NS` (a late sensor).
    ///
    /// Why: the MTi reports at 100 Hz and the drives at the SYNC rate, so
    /// `pose()` is on average half a period (plus the transmission) old when
    /// a frame reads it. A rover on leg-wheels rocks by tenths of a degree
    /// in those 5 ms, and a pose history stamped with the frame time but
    /// holding that older attitude deskews scans and registers keyframes
    /// against a lagging motion.
    pub fn pose_at(&self, time_ns: u64) -> Isometry3<f64> {
        let ahead = |since: u64| {
            let dt = time_ns.saturating_sub(since);
            if dt > MAX_EXTRAPOLATION_NS {
                0.0
            } else {
                dt as f64 * 1e-9
            }
        };
        let mut pose = self.pose;
        if let Some(t) = self.last_imu_ns {
            let q = pose.rotation * rot::exp(&(self.last_gyro * ahead(t)));
            pose.rotation = UnitQuaternion::new_normalize(q.into_inner());
        }
        if self.last_counts.is_some() {
            pose.translation.vector += self.last_velocity * ahead(self.last_wheel_ns);
        }
        pose
    }

    /// Distance travelled since start (sum of step magnitudes), m.
    pub fn distance_m(&self) -> f64 {
        self.distance_m
    }

    pub fn counters(&self) -> &OdometryCounters {
        &self.counters
    }

    /// Is a wheel slipping (was one left out in the last wheel step)?
    pub fn slipping(&self) -> bool {
        self.slipping
    }

    /// Integrate one IMU sample (attitude only).
    pub fn imu(&mut self, s: &ImuInput) {
        self.counters.imu_samples += 1;
        let device = device_attitude(&s.orientation);
        let gyro = Vector3::from(s.gyro);
        let gyro_ok = gyro.iter().all(|v| v.is_finite()) && gyro.norm() <= self.p.max_rate;
        if device.is_none() || !gyro_ok {
            self.counters.imu_rejected += 1;
        }
        let last = self.last_imu_ns.replace(s.time_ns);
        self.last_gyro = if gyro_ok { gyro } else { Vector3::zeros() };
        // How much of the device's roll and pitch to take: all of it at
        // start and after a gap, none for a sample without a time step.
        let mut alpha = 1.0;
        if let Some(last) = last {
            let dt = s.time_ns.saturating_sub(last) as f64 * 1e-9;
            if dt <= 0.0 || dt > self.p.max_imu_gap_s {
                self.counters.imu_gaps += 1;
                if dt <= 0.0 {
                    alpha = 0.0;
                }
            } else {
                if gyro_ok {
                    let q = self.pose.rotation * rot::exp(&(gyro * dt));
                    self.pose.rotation = UnitQuaternion::new_normalize(q.into_inner());
                    self.gyro_yaw += gyro.z * dt;
                    self.gyro_samples += 1;
                }
                let tau = self.p.attitude_time_constant_s;
                if self.attitude_ready && tau > 0.0 {
                    alpha = dt / (tau + dt);
                }
            }
        }
        if let Some(d) = device {
            if alpha > 0.0 {
                self.level(&d, alpha);
            }
        }
    }

    /// Move roll and pitch a fraction `alpha` of the way to the device's,
    /// keeping the heading.
    fn level(&mut self, device: &UnitQuaternion<f64>, alpha: f64) {
        let (roll, pitch, yaw) = rot::to_rpy(&self.pose.rotation);
        let (roll_d, pitch_d, _) = rot::to_rpy(device);
        let ready = self.attitude_ready;
        if ready && (pitch.abs() > MAX_CORRECTED_PITCH || pitch_d.abs() > MAX_CORRECTED_PITCH) {
            // Near gimbal lock the split into roll and yaw is meaningless:
            // rely on the gyro until the body is back.
            return;
        }
        let roll = roll + alpha * rot::wrap_angle(roll_d - roll);
        let pitch = pitch + alpha * (pitch_d - pitch);
        self.pose.rotation = rot::from_rpy(roll, pitch, yaw);
        self.attitude_ready = true;
    }

    /// Integrate new encoder positions (front left, front right, rear left,
    /// rear right) read at `time_ns`. Returns the forward travel of this
    /// step, m (negative backwards).
    pub fn wheels(&mut self, time_ns: u64, counts: [i32; 4]) -> f64 {
        let last = self.last_counts.replace(counts);
        let dt = time_ns.saturating_sub(self.last_wheel_ns) as f64 * 1e-9;
        self.last_wheel_ns = self.last_wheel_ns.max(time_ns);
        let attitude_before = core::mem::replace(&mut self.attitude_at_wheels, self.pose.rotation);
        let gyro_yaw = (self.gyro_samples > 0).then_some(self.gyro_yaw);
        self.gyro_yaw = 0.0;
        self.gyro_samples = 0;
        self.last_velocity = Vector3::zeros();
        let Some(last) = last else {
            return 0.0;
        };
        self.counters.wheel_steps += 1;
        let per_count = 2.0 * core::f64::consts::PI * self.p.wheel_radius_m / self.p.counts_per_rev;
        let mut d = [0.0; 4];
        let mut valid = [false; 4];
        for i in 0..4 {
            // Wrapping difference: the 32-bit position registers roll over.
            d[i] = counts[i].wrapping_sub(last[i]) as f64 * per_count;
            valid[i] = d[i].is_finite() && d[i].abs() <= self.p.max_step_m;
            if !valid[i] {
                self.counters.wheel_glitches[i] += 1;
            }
        }
        if !valid.iter().any(|v| *v) {
            self.counters.rejected_steps += 1;
            return 0.0;
        }
        let v = self.travel(&d, &valid, gyro_yaw, dt, per_count);
        if !v.is_finite() {
            self.counters.rejected_steps += 1;
            return 0.0;
        }
        let mid = rot::slerp(&attitude_before, &self.pose.rotation, 0.5);
        let step = mid * Vector3::new(v, 0.0, 0.0);
        self.pose.translation = Translation3::from(self.pose.translation.vector + step);
        if dt > 0.0 {
            self.last_velocity = step / dt;
        }
        self.distance_m += v.abs();
        v
    }

    /// The forward travel of one step from the wheels' travel `d` (those
    /// marked valid), the gyro's yaw over the step (if the IMU reported),
    /// the step's duration and the travel of one encoder count; updates the
    /// slip counters.
    fn travel(
        &mut self,
        d: &[f64; 4],
        valid: &[bool; 4],
        gyro_yaw: Option<f64>,
        dt: f64,
        per_count: f64,
    ) -> f64 {
        let half_track = 0.5 * self.p.track_width_m * self.p.skid_factor;
        // Each wheel's estimate of the body's forward travel: the gyro's
        // yaw tells how much faster the outer side goes. Without the gyro,
        // only wheels of one side can be compared.
        let yaw_share = gyro_yaw.map_or(0.0, |g| g * half_track);
        let mut c = [0.0; 4];
        for i in 0..4 {
            c[i] = if LEFT[i] {
                d[i] + yaw_share
            } else {
                d[i] - yaw_share
            };
        }
        let tol_for = |median: f64| {
            self.p.slip_speed_tolerance * dt.clamp(0.005, 0.5)
                + self.p.slip_relative_tolerance * median.abs()
                + self.p.skid_factor_uncertainty * yaw_share.abs()
                // Encoder resolution.
                + 2.0 * per_count.abs()
        };
        let mut used = [false; 4];
        let mut ambiguous = false;
        if gyro_yaw.is_some() {
            let (used4, amb, tol) = consensus(&c, valid, &tol_for);
            used = used4;
            ambiguous = amb;
            // Diagnostic: do the sides' mean estimates agree (is the wheels'
            // yaw the gyro's)?
            let side_mean = |left: bool| {
                let (s, n) = (0..4)
                    .filter(|&i| valid[i] && LEFT[i] == left)
                    .fold((0.0, 0.0), |(s, n), i| (s + c[i], n + 1.0));
                (n > 0.0).then(|| s / n)
            };
            if let (Some(l), Some(r)) = (side_mean(true), side_mean(false)) {
                if (l - r).abs() > 2.0 * tol {
                    self.counters.yaw_mismatches += 1;
                }
            }
        } else {
            // Front against rear of each side.
            for side in [[0, 2], [1, 3]] {
                let mut one = [false; 4];
                for i in side {
                    one[i] = valid[i];
                }
                let (u, amb, _) = consensus(&c, &one, &tol_for);
                for i in side {
                    used[i] = u[i];
                }
                ambiguous |= amb;
            }
        }
        // Forward travel: the mean of the sides (chi cancels) when both
        // have a trusted wheel, else the one side's yaw-corrected estimate.
        let mean_of = |vals: &[f64; 4], pick: &dyn Fn(usize) -> bool| {
            let (s, n) = (0..4)
                .filter(|&i| used[i] && pick(i))
                .fold((0.0, 0.0), |(s, n), i| (s + vals[i], n + 1.0));
            (n > 0.0).then(|| s / n)
        };
        let v = match (mean_of(d, &|i| LEFT[i]), mean_of(d, &|i| !LEFT[i])) {
            (Some(l), Some(r)) => 0.5 * (l + r),
            _ => mean_of(&c, &|_| true).unwrap_or(0.0),
        };
        let slip = used != *valid;
        if slip {
            self.counters.slip_steps += 1;
            if !self.slipping {
                self.counters.slip_events += 1;
            }
            for i in 0..4 {
                if valid[i] && !used[i] {
                    self.counters.wheel_slips[i] += 1;
                }
            }
            if ambiguous {
                self.counters.ambiguous_steps += 1;
            }
        }
        self.slipping = slip;
        v
    }
}

/// Which of the `valid` estimates `c` agree with their median within
/// `tol(median)`; without any, those within the tolerance of the
/// smallest-magnitude estimate (true in the second place). Also returns the
/// tolerance used.
fn consensus(c: &[f64; 4], valid: &[bool; 4], tol: &dyn Fn(f64) -> f64) -> ([bool; 4], bool, f64) {
    let mut vals = [0.0; 4];
    let mut n = 0;
    for i in 0..4 {
        if valid[i] {
            vals[n] = c[i];
            n += 1;
        }
    }
    let mut used = [false; 4];
    if n == 0 {
        return (used, false, tol(0.0));
    }
    let sorted = &mut vals[..n];
    sorted.sort_unstable_by(f64::total_cmp);
    let median = if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    };
    let t = tol(median);
    let mut agree = 0;
    for i in 0..4 {
        used[i] = valid[i] && (c[i] - median).abs() <= t;
        agree += used[i] as usize;
    }
    if agree > 0 {
        return (used, false, t);
    }
    // No consensus: a wheel that spins or skids reads too much more often
    // than too little, so trust the smallest.
    let mut best = 0;
    let mut best_abs = f64::INFINITY;
    for i in 0..4 {
        if valid[i] && c[i].abs() < best_abs {
            best = i;
            best_abs = c[i].abs();
        }
    }
    let t = tol(c[best]);
    for i in 0..4 {
        used[i] = valid[i] && (c[i] - c[best]).abs() <= t;
    }
    (used, true, t)
}

#[cfg(test)]
mod tests;
