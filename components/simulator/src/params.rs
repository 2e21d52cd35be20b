//! Settings of the internal simulator. Only the keys `[simulator]` has
//! always had are read and written; the rest (the rover's build, the
//! follower, the world's making) keep their defaults or are set by the
//! caller.

use speleo_control::{AccelLimits, FollowerParams, SkidSteer};
use speleo_params::{range, ParamError};
use speleo_physics::PhysicsParams;

/// The internal simulator's settings.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(default, deny_unknown_fields)
)]
pub struct SimulatorParams {
    /// The rover model (the same build the simulated hardware uses).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub physics: PhysicsParams,
    /// The follower clone: the control task's settings.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub follower: FollowerParams,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub limits: AccelLimits,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub skid: SkidSteer,
    /// TSDF voxel side, m (the paper's mesh: 5 cm), and its block pool.
    pub voxel_m: f64,
    pub max_blocks: usize,
    /// The world is the box around the plan grown by this, m.
    pub margin_m: f64,
    /// Keyframes whose sensor is within this of that box are integrated, m,
    /// the newest `newest_keyframes` of them (older passes may not agree
    /// with them before SLAM closes the loop).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub cloud_range_m: f64,
    pub newest_keyframes: usize,
    /// Width of a meshing tile (one rapier collider each), m.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub tile_m: f64,
    /// Physics step, s.
    pub dt_s: f64,
    /// The rover stands this long before it drives, s (it settles).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub settle_s: f64,
    /// The goal is reached within this distance, m.
    pub goal_tolerance_m: f64,
    /// The time allowed: this many times the plan's length at cruise
    /// speed, plus `time_extra_s`.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub time_factor: f64,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub time_extra_s: f64,
    /// A tilt over this is a tip-over, deg.
    pub tip_over_deg: f64,
    /// Commanded for this long without this much progress: stuck.
    pub stuck_after_s: f64,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub stuck_progress_m: f64,
    /// Ground under base_link, m.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub base_height_m: f64,
    /// Start the simulated rover pitched and rolled as it stands (the
    /// start's [`crate::Stance`]), the unseen ground under it following
    /// that tilt; off, it is put down level, yaw only. On: replayed on the
    /// true worlds, the dev matrix's plans agree with the truth in 90 % of
    /// verdicts against 80 % put down level (`docs/margins.md`), and the
    /// dev matrix with it, the way home's shortcuts and the grip read
    /// passed more missions than without (`campaigns/accepted/`).
    pub start_tilted: bool,
    /// With `start_tilted` off, a rover tilted more than this still starts
    /// as it stands, deg (90: never). Put down level on the lava tube's
    /// muddy entrance, pitched 20°, the simulated rover drove off the
    /// edge of the level pad laid under it and tipped, on every way down
    /// there was: the true rover, which had slid there, was stranded.
    pub start_tilted_over_deg: f64,
    /// A plan that took the rover down more than this is driven back too
    /// when asked ([`crate::InternalSim::check_way_back`]), m; 0: never.
    /// In the lava tube (2026-12-02, with steps charged by their contact
    /// load) a goal 1.65 m down a 21° slope at the far end left the rover
    /// in a pit it could not climb out of (stuck on the true surface too)
    /// and stranded it 186 m from home; checked from 1 m down, the same
    /// mission came home (coverage 0.98, 6 plans refused as `NoWayBack`).
    /// Off by default still: the check's extra driving delays verdicts,
    /// and on the short tube that course stranded the rover.
    pub way_back_drop_m: f64,
    /// A goal reached with a wheel's hub more than this over the ground
    /// its radius reaches, or over none, is refused (`Overhang`), m; 0:
    /// never. It sees the ground built (mesh, pad and strip), so it
    /// refuses goals where that ends under a hub, such as where the strip
    /// drops past a seen edge. It misses a roof's unseen rim: no ray
    /// returns past it, the strip runs on at the roof's height and holds
    /// the wheels (the garage's roof goal 0.15 m from the rim passed).
    pub overhang_depth_m: f64,
    /// A plan that reaches its goal is driven a second time, pessimistic,
    /// and passes only if that reaches the goal too: on the same ground
    /// with its friction at most this (0: no second rollout) ... Off: on
    /// the dev matrix, mud's grip on every climb stranded 8 missions of
    /// 17 on their way home (`docs/mission-history.md`, 2026-12-05).
    pub pessimistic_friction: f64,
    /// ... the rover started as it stands, pitched and rolled, and tipped
    /// over this much under `tip_over_deg`, deg (the tilt the map gets
    /// wrong).
    pub pessimistic_tilt_margin_deg: f64,
    /// The pessimistic rollout is driven only for plans whose nominal
    /// rollout climbed more than this above the start, m: where the
    /// wheels hold the rover against the slope, so a grip the scans
    /// cannot read decides whether it comes back down (0: every plan).
    pub pessimistic_climb_m: f64,
    /// Ground whose reflectance reads under this is driven at mud's grip,
    /// the rest at rock's (0: rock everywhere). The reflectance is the
    /// brightest return of the ground's voxel with its incidence taken out
    /// (see `grip.rs`): rock reads about 60, mud 25, boulders 90, concrete
    /// 110, at any range and angle the ground is seen from.
    pub low_grip_reflectance: f64,
    /// The most tilt the rover is simulated at on ground read as low
    /// grip, deg (0: no limit): steeper, the plan is refused
    /// ([`Outcome::TooSteepForGrip`](crate::Outcome::TooSteepForGrip)),
    /// up or down, unless the rover started steeper. The map's
    /// slope is gentler than the true one where a climb stalls, so the
    /// simulated physics passes climbs the true mud does not hold.
    pub low_grip_max_tilt_deg: f64,
}

impl Default for SimulatorParams {
    fn default() -> Self {
        let physics = PhysicsParams::default();
        SimulatorParams {
            follower: FollowerParams {
                lookahead_m: 0.8,
                cruise_speed: 0.4,
                max_yaw_rate: 0.8,
                goal_tolerance_m: 0.2,
            },
            limits: AccelLimits {
                max_accel: 0.5,
                max_decel: 1.0,
                max_yaw_accel: 2.0,
            },
            skid: SkidSteer {
                wheel_radius_m: physics.wheel_radius_m,
                track_width_m: physics.track_width_m,
                skid_factor: 1.0,
                max_wheel_speed: physics.max_wheel_speed,
            },
            voxel_m: 0.05,
            max_blocks: 16_384,
            margin_m: 2.0,
            cloud_range_m: 15.0,
            newest_keyframes: 20,
            tile_m: 0.25,
            dt_s: 0.01,
            settle_s: 0.5,
            goal_tolerance_m: 0.5,
            time_factor: 2.0,
            time_extra_s: 10.0,
            tip_over_deg: 45.0,
            stuck_after_s: 6.0,
            stuck_progress_m: 0.1,
            base_height_m: 0.9 * physics.wheel_radius_m,
            start_tilted: true,
            start_tilted_over_deg: 15.0,
            way_back_drop_m: 0.0,
            overhang_depth_m: 0.3,
            // The lowest grip the rover's model knows (mud): the map
            // cannot tell mud from rock.
            pessimistic_friction: 0.0,
            pessimistic_tilt_margin_deg: 0.0,
            pessimistic_climb_m: 0.5,
            // Between mud's reflectance (25) and rock's (60).
            low_grip_reflectance: 40.0,
            low_grip_max_tilt_deg: 22.0,
            physics,
        }
    }
}

impl SimulatorParams {
    /// The first configurable setting out of the range the rover accepts,
    /// by its key (stricter than [`SimulatorParams::check`]).
    pub fn validate(&self) -> Result<(), ParamError> {
        range("voxel_m", self.voxel_m, 0.01, 0.5, "0.01..=0.5")?;
        range("max_blocks", self.max_blocks, 64, 1 << 20, "64..=1048576")?;
        range("margin_m", self.margin_m, 0.5, 20.0, "0.5..=20")?;
        range("dt_s", self.dt_s, 0.0005, 0.01, "0.0005..=0.01")?;
        range(
            "goal_tolerance_m",
            self.goal_tolerance_m,
            0.05,
            5.0,
            "0.05..=5",
        )?;
        range("tip_over_deg", self.tip_over_deg, 5.0, 90.0, "5..=90")?;
        range("stuck_after_s", self.stuck_after_s, 0.5, 120.0, "0.5..=120")?;
        range(
            "newest_keyframes",
            self.newest_keyframes,
            1,
            100_000,
            "1..=100000",
        )?;
        range(
            "start_tilted_over_deg",
            self.start_tilted_over_deg,
            0.0,
            90.0,
            "0..=90",
        )?;
        range(
            "way_back_drop_m",
            self.way_back_drop_m,
            0.0,
            100.0,
            "0..=100",
        )?;
        range(
            "overhang_depth_m",
            self.overhang_depth_m,
            0.0,
            10.0,
            "0..=10",
        )?;
        range(
            "pessimistic_friction",
            self.pessimistic_friction,
            0.0,
            2.0,
            "0..=2",
        )?;
        range(
            "pessimistic_tilt_margin_deg",
            self.pessimistic_tilt_margin_deg,
            0.0,
            30.0,
            "0..=30",
        )?;
        range(
            "low_grip_reflectance",
            self.low_grip_reflectance,
            0.0,
            1275.0,
            "0..=1275",
        )?;
        range(
            "low_grip_max_tilt_deg",
            self.low_grip_max_tilt_deg,
            0.0,
            90.0,
            "0..=90",
        )?;
        range(
            "pessimistic_climb_m",
            self.pessimistic_climb_m,
            0.0,
            100.0,
            "0..=100",
        )
    }

    /// Why these settings cannot work, if they cannot.
    pub fn check(&self) -> Result<(), String> {
        let positive = [
            ("voxel_m", self.voxel_m),
            ("margin_m", self.margin_m),
            ("tile_m", self.tile_m),
            ("dt_s", self.dt_s),
            ("goal_tolerance_m", self.goal_tolerance_m),
            ("time_factor", self.time_factor),
            ("tip_over_deg", self.tip_over_deg),
            ("stuck_after_s", self.stuck_after_s),
        ];
        for (k, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("simulator {k} must be a positive number, is {v}"));
            }
        }
        if !(self.way_back_drop_m.is_finite() && self.way_back_drop_m >= 0.0) {
            return Err(format!(
                "simulator way_back_drop_m must be 0 or more, is {}",
                self.way_back_drop_m
            ));
        }
        if !(self.overhang_depth_m.is_finite() && self.overhang_depth_m >= 0.0) {
            return Err(format!(
                "simulator overhang_depth_m must be 0 or more, is {}",
                self.overhang_depth_m
            ));
        }
        if !(0.0..=2.0).contains(&self.pessimistic_friction) {
            return Err(format!(
                "simulator pessimistic_friction must be within 0..=2, is {}",
                self.pessimistic_friction
            ));
        }
        if !(0.0..self.tip_over_deg).contains(&self.pessimistic_tilt_margin_deg) {
            return Err(format!(
                "simulator pessimistic_tilt_margin_deg must be 0 or more and under tip_over_deg, is {}",
                self.pessimistic_tilt_margin_deg
            ));
        }
        if !(0.0..=90.0).contains(&self.low_grip_max_tilt_deg) {
            return Err(format!(
                "simulator low_grip_max_tilt_deg must be within 0..=90, is {}",
                self.low_grip_max_tilt_deg
            ));
        }
        if !(0.0..=1275.0).contains(&self.low_grip_reflectance) {
            return Err(format!(
                "simulator low_grip_reflectance must be within 0..=1275, is {}",
                self.low_grip_reflectance
            ));
        }
        if !(0.0..=100.0).contains(&self.pessimistic_climb_m) {
            return Err(format!(
                "simulator pessimistic_climb_m must be within 0..=100, is {}",
                self.pessimistic_climb_m
            ));
        }
        if !(0.0..=90.0).contains(&self.start_tilted_over_deg) {
            return Err(format!(
                "simulator start_tilted_over_deg must be within 0..=90, is {}",
                self.start_tilted_over_deg
            ));
        }
        if self.max_blocks == 0 {
            return Err("simulator max_blocks must be positive".into());
        }
        if self.newest_keyframes == 0 {
            return Err("simulator newest_keyframes must be positive".into());
        }
        self.physics.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_are_valid_and_a_value_out_of_range_is_named() {
        SimulatorParams::default().validate().expect("the rover's");
        let p = SimulatorParams {
            dt_s: 0.02,
            ..SimulatorParams::default()
        };
        assert_eq!(p.validate().expect_err("too coarse").key(), "dt_s");
    }
}
