//! The TOML configuration. Every table refuses unknown keys, and every value
//! is range-checked with a message that names its key.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use thiserror::Error;

mod compose;
mod exploration;
mod maps;
mod planner;
mod planner_steps;
mod simulator;
mod slam;
pub use exploration::ExplorationConfig;
pub use maps::MapsConfig;
pub use planner::PlannerConfig;
pub use planner_steps::{PlannerStepUnits, MAX_STEP_UNITS, STEP_PHASES};
pub use simulator::SimulatorConfig;
pub use slam::SlamConfig;

#[derive(Debug, Error)]
pub enum ConfigError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("configuration: {0}")]
    Parse(String),
    #[error("configuration: `{key}` = {value} is out of range ({range})")]
    OutOfRange {
        key: String,
        value: String,
        range: &'static str,
    },
    #[error("configuration: `{key}`: {why}")]
    Invalid { key: String, why: String },
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    pub executive: ExecutiveConfig,
    /// Per-task overrides of the schedule table, by task name.
    pub tasks: BTreeMap<String, TaskOverride>,
    pub sim: SimConfig,
    pub rover: RoverConfig,
    pub control: ControlConfig,
    pub lidar: LidarConfig,
    pub slam: SlamConfig,
    pub maps: MapsConfig,
    pub planner: PlannerConfig,
    pub exploration: ExplorationConfig,
    pub simulator: SimulatorConfig,
    pub health: HealthConfig,
    pub record: RecordConfig,
    pub devices: DevicesConfig,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExecutiveConfig {
    pub minor_frame_us: u32,
    /// Time kept free in every frame.
    pub margin_us: u32,
    /// Unix time (s) that virtual time 0 maps to in recordings of sim runs.
    pub epoch_unix_s: u64,
    /// SCHED_FIFO priority asked for by `speleo run`.
    pub realtime_priority: i32,
    /// Apply overrun policies on the virtual clock too (budget tests). Off by
    /// default so sim and replay outputs do not depend on machine speed.
    pub enforce_policies_in_sim: bool,
}

impl Default for ExecutiveConfig {
    fn default() -> Self {
        ExecutiveConfig {
            minor_frame_us: 10_000,
            margin_us: 1_000,
            epoch_unix_s: 1_767_225_600, // 2026-01-01T00:00:00Z
            realtime_priority: 80,
            enforce_policies_in_sim: false,
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TaskOverride {
    pub divisor: Option<u32>,
    pub offset: Option<u32>,
    pub budget_us: Option<u32>,
    pub policy: Option<String>,
    pub steps: Option<u32>,
    pub quantum: Option<u32>,
    pub window_us: Option<u32>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    pub seed: u64,
    /// Seed of the sensors' noise alone (the LiDAR's ranges and the
    /// IMU's), the world and the start keeping `seed`: the same mission
    /// with another noise stream, to see how much its course turns on
    /// millimetres (none: `seed`).
    pub noise_seed: Option<u64>,
    /// `lava-tube`, `garage`, `flat`, or a .ply/.obj/.stl mesh file.
    pub world: String,
    pub duration_s: f64,
    /// Simulate the HDL-32E (rays against the world).
    pub lidar: bool,
    /// Its rotation rate, 5 to 20 Hz.
    pub lidar_rate_hz: f64,
    /// Threads that cast its rays, 1 or 2 (the second casts half of each
    /// frame's rays; the same bytes either way).
    pub lidar_cast_threads: usize,
    /// `physics` (rapier3d) or `kinematic` (flat-ground skid-steer, fast).
    pub rover_model: String,
    /// Drive the world's route (when it has one) instead of `control.path`.
    pub follow_route: bool,
    /// With `follow_route`: drive the route to its end and back to the start
    /// (as the paper's data set was taken), instead of one way.
    pub out_and_back: bool,
    /// With `follow_route`: drive only this much of the route, m (0: all).
    pub route_length_m: f64,
    /// IMU frame against base_link, roll, pitch, yaw in degrees (what the
    /// SLAM bias state estimates).
    pub imu_misalignment_deg: [f64; 3],
    /// Fault injection: a wrong loop closure handed to SLAM.
    pub false_loop_closure: Option<FalseLoopClosure>,
    /// Fault injection: `KIND@START[+DURATION][:WHEEL]` (see `speleo sim
    /// --help`), e.g. `lidar-dropout@20+5`.
    pub faults: Vec<String>,
    /// The physics rover's build.
    pub rover: speleo_physics::PhysicsParams,
    /// Where the rover starts instead of the world's start: x, y, floor
    /// z (m, world frame) and yaw (degrees), or one of the world's
    /// waypoints by name (`speleo world waypoints`). Home is there too;
    /// the world's scripted route, which begins at its own start, is
    /// dropped.
    pub start: Option<StartSpec>,
    /// What makes the mission a success (the report's `success`).
    pub success: speleo_campaign::success::SuccessCriteria,
}

/// A start: a pose, or a waypoint's name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum StartSpec {
    Pose([f64; 4]),
    Waypoint(String),
}

/// A loop closure that claims keyframe `newer` sits at `offset_m` and
/// `yaw_deg` from where SLAM puts it relative to keyframe `older`, with the
/// confidence of a real registration: perceptual aliasing, as a self-similar
/// tube invites. Added once both keyframes exist.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FalseLoopClosure {
    pub older: usize,
    pub newer: usize,
    pub offset_m: [f64; 3],
    #[serde(default)]
    pub yaw_deg: f64,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            seed: 1,
            noise_seed: None,
            world: "lava-tube".into(),
            duration_s: 7200.0,
            lidar: true,
            lidar_rate_hz: 10.0,
            lidar_cast_threads: 2,
            rover_model: "physics".into(),
            follow_route: true,
            out_and_back: true,
            route_length_m: 0.0,
            imu_misalignment_deg: [0.0; 3],
            false_loop_closure: None,
            faults: Vec::new(),
            rover: speleo_physics::PhysicsParams::default(),
            start: None,
            success: Default::default(),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RoverConfig {
    pub wheel_radius_m: f64,
    pub track_width_m: f64,
    pub skid_factor: f64,
    pub max_wheel_speed: f64,
}

impl Default for RoverConfig {
    fn default() -> Self {
        let r = speleo_twin::RoverParams::default();
        RoverConfig {
            wheel_radius_m: r.wheel_radius_m,
            track_width_m: r.track_width_m,
            skid_factor: r.skid_factor,
            max_wheel_speed: r.max_wheel_speed,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ControlConfig {
    /// Scripted path, (x, y) in metres in the odometry frame.
    pub path: Vec<[f64; 2]>,
    pub looped: bool,
    pub cruise_speed: f64,
    pub lookahead_m: f64,
    pub max_yaw_rate: f64,
    /// Commands older than this are not sent; the wheels get zero.
    pub command_timeout_ms: u32,
    /// Ramps of the body command: m/s^2 speeding up and braking, rad/s^2.
    pub max_accel: f64,
    pub max_decel: f64,
    pub max_yaw_accel: f64,
    /// The safety monitor (on plans the exploration follows): the rover
    /// stops beyond this tilt, deg; after this long commanded without
    /// progress, s; this far from its path, m.
    pub max_tilt_deg: f64,
    pub stuck_after_s: f64,
    pub max_cross_track_m: f64,
}

impl Default for ControlConfig {
    fn default() -> Self {
        ControlConfig {
            path: vec![
                [0.0, 0.0],
                [6.0, 0.0],
                [8.0, 2.0],
                [8.0, 4.0],
                [6.0, 6.0],
                [0.0, 6.0],
                [-2.0, 4.0],
                [-2.0, 2.0],
            ],
            looped: true,
            cruise_speed: 0.4,
            lookahead_m: 0.8,
            max_yaw_rate: 0.8,
            command_timeout_ms: 100,
            max_accel: 0.5,
            max_decel: 1.0,
            max_yaw_accel: 2.0,
            max_tilt_deg: 30.0,
            stuck_after_s: 5.0,
            max_cross_track_m: 0.8,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarConfig {
    /// VeloView XML or ROS YAML calibration; empty: the nominal HDL-32E table.
    pub calibration: String,
    /// Azimuth at which revolutions are split into frames, degrees.
    pub cut_angle_deg: f64,
    /// "continuous", "veloview" or "velodyne-decoder" (see the decoder).
    pub interpolation: String,
    /// Returns closer than this are dropped (the rover's own body).
    pub min_range_m: f64,
    /// Frame buffer size; points beyond it are dropped and counted.
    pub max_points_per_frame: u32,
    /// Sensor position on base_link (the chassis frame at axle height; x, y,
    /// z, m) and orientation (roll, pitch, yaw, deg).
    pub mount_xyz: [f64; 3],
    pub mount_rpy_deg: [f64; 3],
}

impl Default for LidarConfig {
    fn default() -> Self {
        LidarConfig {
            calibration: String::new(),
            cut_angle_deg: 0.0,
            interpolation: "continuous".into(),
            min_range_m: 0.0,
            // 69,504 returns per revolution at 10 Hz; twice that at 5 Hz.
            max_points_per_frame: 140_000,
            mount_xyz: [0.0, 0.0, 0.35],
            mount_rpy_deg: [0.0, 0.0, 0.0],
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HealthConfig {
    pub imu_timeout_ms: u32,
    /// A drive whose heartbeat (every 100 ms by default) is older than this
    /// is lost: every wheel stops and the safe schedule starts.
    pub drive_heartbeat_timeout_ms: u32,
    pub startup_grace_ms: u32,
    /// Enter the safe schedule when a device goes silent.
    pub safe_mode_on_stale: bool,
    /// The LiDAR's packets (about 1,800 a second) stopping this long is a
    /// dropout. Watched from its first packet on.
    pub lidar_timeout_ms: u32,
    /// A wheel the odometry leaves out of most of its steps for this long
    /// is stuck or spinning.
    pub wheel_disagreement_ms: u32,
    /// This many task overruns within a second are a storm (only when the
    /// executive enforces its budgets; 0: never).
    pub overrun_storm_per_s: u32,
    /// A jump of the frame clock at least this long is a fault.
    pub clock_jump_ms: u32,
    /// Leave the safe schedule once nothing has been found for this long
    /// (0: stay in it until restarted).
    pub recover_after_ms: u32,
    /// Reset a drive's fault after it has stood this long, and again as
    /// often while it stays (0: never reset).
    pub drive_fault_reset_ms: u32,
}

impl Default for HealthConfig {
    fn default() -> Self {
        HealthConfig {
            imu_timeout_ms: 50,
            drive_heartbeat_timeout_ms: 300,
            startup_grace_ms: 500,
            safe_mode_on_stale: true,
            lidar_timeout_ms: 300,
            wheel_disagreement_ms: 300,
            overrun_storm_per_s: 20,
            clock_jump_ms: 100,
            recover_after_ms: 2_000,
            drive_fault_reset_ms: 1_000,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RecordConfig {
    /// Uncompressed size at which a chunk is closed and written out; a killed
    /// process loses at most the open chunk.
    pub chunk_size_kib: u32,
    /// "zstd" or "none".
    pub compression: String,
    /// Message buffers shared with the writer thread, allocated at start-up.
    pub pool_messages: u32,
    /// Scheduler telemetry period, frames.
    pub telemetry_every_frames: u32,
    /// Record one decoded LiDAR revolution (`/lidar/points`) in this many;
    /// the raw packets of every revolution are always recorded.
    pub cloud_every: u32,
}

impl Default for RecordConfig {
    fn default() -> Self {
        RecordConfig {
            chunk_size_kib: 512,
            compression: "zstd".into(),
            pool_messages: 2048,
            telemetry_every_frames: 100,
            cloud_every: 10,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DevicesConfig {
    /// Local address the HDL-32E data packets are received on.
    pub lidar_bind: String,
    /// Local address of the position packets (UDP 8308); empty: not received.
    pub lidar_position_bind: String,
    /// The sensor's address; datagrams from anywhere else are dropped.
    pub lidar_sensor: String,
    pub imu_port: String,
    pub imu_baud: u32,
    /// `socketcan`: a kernel CAN interface (`can_interface`); `slcan`: a
    /// serial-line CAN adapter (CANable, USBtin, CANUSB) on `can_serial_port`.
    pub can_transport: String,
    pub can_interface: String,
    pub can_serial_port: String,
    /// The adapter's serial line rate (USB adapters ignore it).
    pub can_serial_baud: u32,
    /// The bus's bit rate, which `slcan` sets on the adapter (a SocketCAN
    /// interface is set with `ip link`).
    pub can_bit_rate: u32,
}

impl Default for DevicesConfig {
    fn default() -> Self {
        DevicesConfig {
            lidar_bind: "0.0.0.0:2368".into(),
            lidar_position_bind: "0.0.0.0:8308".into(),
            lidar_sensor: "192.168.1.201:2368".into(),
            imu_port: "/dev/ttyUSB0".into(),
            imu_baud: 921_600,
            can_transport: "socketcan".into(),
            can_interface: "can0".into(),
            can_serial_port: "/dev/ttyACM0".into(),
            can_serial_baud: 115_200,
            can_bit_rate: 1_000_000,
        }
    }
}

impl ConfigError {
    /// A component's refusal of a value in `section`, named by its key there.
    pub(crate) fn of_param(section: &str, e: speleo_params::ParamError) -> ConfigError {
        match e.within(section) {
            speleo_params::ParamError::OutOfRange { key, value, range } => {
                ConfigError::OutOfRange { key, value, range }
            }
            speleo_params::ParamError::Invalid { key, why } => ConfigError::Invalid { key, why },
        }
    }
}

fn range<T: PartialOrd + std::fmt::Display>(
    key: &str,
    v: T,
    lo: T,
    hi: T,
    text: &'static str,
) -> Result<(), ConfigError> {
    if v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.into(),
            value: v.to_string(),
            range: text,
        })
    }
}

impl Config {
    pub fn from_toml(text: &str) -> Result<Config, ConfigError> {
        let c: Config = toml::from_str(text).map_err(|e| ConfigError::Parse(e.to_string()))?;
        c.validate()?;
        Ok(c)
    }

    pub fn load(path: &Path) -> Result<Config, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml(&text).map_err(|e| match e {
            ConfigError::Parse(m) => ConfigError::Parse(format!("{}: {m}", path.display())),
            other => other,
        })
    }

    /// The effective configuration as TOML (stored in every recording).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    pub fn validate(&self) -> Result<(), ConfigError> {
        let e = &self.executive;
        range(
            "executive.minor_frame_us",
            e.minor_frame_us,
            100,
            1_000_000,
            "100..=1000000",
        )?;
        range(
            "executive.margin_us",
            e.margin_us,
            0,
            e.minor_frame_us,
            "0..=minor_frame_us",
        )?;
        range(
            "executive.realtime_priority",
            e.realtime_priority,
            1,
            99,
            "1..=99",
        )?;
        for (name, t) in &self.tasks {
            if let Some(p) = &t.policy {
                if speleo_scheduler::OverrunPolicy::parse(p).is_none() {
                    return Err(ConfigError::Invalid {
                        key: format!("tasks.{name}.policy"),
                        why: format!(
                            "unknown policy \"{p}\" (use skip, reuse-last, degrade or safe-mode)"
                        ),
                    });
                }
            }
            if let Some(d) = t.divisor {
                range(
                    &format!("tasks.{name}.divisor"),
                    d,
                    1,
                    100_000,
                    "1..=100000",
                )?;
            }
            if let Some(b) = t.budget_us {
                range(
                    &format!("tasks.{name}.budget_us"),
                    b,
                    1,
                    10_000_000,
                    "1..=10000000",
                )?;
            }
        }
        let s = &self.sim;
        range("sim.duration_s", s.duration_s, 0.0, 1.0e7, "0..=10000000")?;
        range("sim.lidar_rate_hz", s.lidar_rate_hz, 5.0, 20.0, "5..=20")?;
        range(
            "sim.lidar_cast_threads",
            s.lidar_cast_threads,
            1,
            2,
            "1..=2",
        )?;
        range(
            "sim.route_length_m",
            s.route_length_m,
            0.0,
            1.0e6,
            "0..=1000000",
        )?;
        match &s.start {
            Some(StartSpec::Pose(st)) if !st.iter().all(|v| v.is_finite()) => {
                return Err(ConfigError::Invalid {
                    key: "sim.start".into(),
                    why: "x, y, floor z (m) and yaw (degrees) must be finite numbers".into(),
                });
            }
            Some(StartSpec::Waypoint(w)) if w.trim().is_empty() => {
                return Err(ConfigError::Invalid {
                    key: "sim.start".into(),
                    why: "name a waypoint of the world or give x, y, z, yaw".into(),
                });
            }
            _ => {}
        }
        if let Err(why) = s.success.validate("sim.success") {
            return Err(ConfigError::Invalid {
                key: "sim.success".into(),
                why,
            });
        }
        if s.world.is_empty() {
            return Err(ConfigError::Invalid {
                key: "sim.world".into(),
                why: "name a world (lava-tube, short-tube, garage, boulders, flat) or a .ply/.obj/.stl file".into(),
            });
        }
        if !["physics", "kinematic"].contains(&s.rover_model.as_str()) {
            return Err(ConfigError::Invalid {
                key: "sim.rover_model".into(),
                why: format!("\"{}\": use physics or kinematic", s.rover_model),
            });
        }
        for (k, a) in ["roll", "pitch", "yaw"].iter().zip(s.imu_misalignment_deg) {
            range(
                &format!("sim.imu_misalignment_deg ({k})"),
                a,
                -30.0,
                30.0,
                "-30..=30",
            )?;
        }
        if let Some(f) = &s.false_loop_closure {
            if f.older >= f.newer {
                return Err(ConfigError::Invalid {
                    key: "sim.false_loop_closure".into(),
                    why: format!("older ({}) must come before newer ({})", f.older, f.newer),
                });
            }
            for (k, v) in ["x", "y", "z"].iter().zip(f.offset_m) {
                range(
                    &format!("sim.false_loop_closure.offset_m ({k})"),
                    v,
                    -1000.0,
                    1000.0,
                    "-1000..=1000",
                )?;
            }
            range(
                "sim.false_loop_closure.yaw_deg",
                f.yaw_deg,
                -180.0,
                180.0,
                "-180..=180",
            )?;
        }
        s.rover.validate().map_err(|why| ConfigError::Invalid {
            key: "sim.rover".into(),
            why,
        })?;
        let r = &self.rover;
        range(
            "rover.wheel_radius_m",
            r.wheel_radius_m,
            0.01,
            2.0,
            "0.01..=2",
        )?;
        range(
            "rover.track_width_m",
            r.track_width_m,
            0.05,
            5.0,
            "0.05..=5",
        )?;
        range("rover.skid_factor", r.skid_factor, 1.0, 5.0, "1..=5")?;
        range(
            "rover.max_wheel_speed",
            r.max_wheel_speed,
            0.1,
            100.0,
            "0.1..=100",
        )?;
        let c = &self.control;
        if c.path.len() < 2 || c.path.len() > speleo_control::MAX_WAYPOINTS {
            return Err(ConfigError::Invalid {
                key: "control.path".into(),
                why: format!(
                    "needs 2 to {} waypoints, has {}",
                    speleo_control::MAX_WAYPOINTS,
                    c.path.len()
                ),
            });
        }
        if c.path.iter().flatten().any(|v| !v.is_finite()) {
            return Err(ConfigError::Invalid {
                key: "control.path".into(),
                why: "waypoints must be finite numbers".into(),
            });
        }
        range("control.cruise_speed", c.cruise_speed, 0.0, 5.0, "0..=5")?;
        range(
            "control.lookahead_m",
            c.lookahead_m,
            0.05,
            20.0,
            "0.05..=20",
        )?;
        range(
            "control.max_yaw_rate",
            c.max_yaw_rate,
            0.01,
            10.0,
            "0.01..=10",
        )?;
        range(
            "control.command_timeout_ms",
            c.command_timeout_ms,
            10,
            10_000,
            "10..=10000",
        )?;
        let l = &self.lidar;
        range(
            "lidar.cut_angle_deg",
            l.cut_angle_deg,
            0.0,
            360.0,
            "0..=360",
        )?;
        range("lidar.min_range_m", l.min_range_m, 0.0, 100.0, "0..=100")?;
        range(
            "lidar.max_points_per_frame",
            l.max_points_per_frame,
            1_000,
            1_000_000,
            "1000..=1000000",
        )?;
        if !["continuous", "veloview", "velodyne-decoder"].contains(&l.interpolation.as_str()) {
            return Err(ConfigError::Invalid {
                key: "lidar.interpolation".into(),
                why: format!(
                    "\"{}\" is not continuous, veloview or velodyne-decoder",
                    l.interpolation
                ),
            });
        }
        if l.mount_xyz
            .iter()
            .chain(&l.mount_rpy_deg)
            .any(|v| !v.is_finite())
        {
            return Err(ConfigError::Invalid {
                key: "lidar.mount_xyz".into(),
                why: "mount values must be finite numbers".into(),
            });
        }
        self.maps.validate()?;
        self.planner.validate(self.maps.mls_resolution_m)?;
        self.exploration.validate()?;
        self.simulator.validate()?;
        for (key, v, lo, hi, text) in [
            ("control.max_accel", c.max_accel, 0.01, 20.0, "0.01..=20"),
            ("control.max_decel", c.max_decel, 0.01, 20.0, "0.01..=20"),
            (
                "control.max_yaw_accel",
                c.max_yaw_accel,
                0.01,
                50.0,
                "0.01..=50",
            ),
            ("control.max_tilt_deg", c.max_tilt_deg, 1.0, 90.0, "1..=90"),
            (
                "control.stuck_after_s",
                c.stuck_after_s,
                0.1,
                600.0,
                "0.1..=600",
            ),
            (
                "control.max_cross_track_m",
                c.max_cross_track_m,
                0.05,
                50.0,
                "0.05..=50",
            ),
        ] {
            range(key, v, lo, hi, text)?;
        }
        self.slam
            .params
            .validate()
            .map_err(|e| ConfigError::of_param("slam", e))?;
        let h = &self.health;
        range(
            "health.imu_timeout_ms",
            h.imu_timeout_ms,
            1,
            60_000,
            "1..=60000",
        )?;
        range(
            "health.drive_heartbeat_timeout_ms",
            h.drive_heartbeat_timeout_ms,
            1,
            60_000,
            "1..=60000",
        )?;
        range(
            "health.startup_grace_ms",
            h.startup_grace_ms,
            0,
            600_000,
            "0..=600000",
        )?;
        for (key, v) in [
            ("health.lidar_timeout_ms", h.lidar_timeout_ms),
            ("health.wheel_disagreement_ms", h.wheel_disagreement_ms),
            ("health.clock_jump_ms", h.clock_jump_ms),
        ] {
            range(key, v, 1, 60_000, "1..=60000")?;
        }
        for (key, v) in [
            ("health.overrun_storm_per_s", h.overrun_storm_per_s),
            ("health.recover_after_ms", h.recover_after_ms),
            ("health.drive_fault_reset_ms", h.drive_fault_reset_ms),
        ] {
            range(key, v, 0, 600_000, "0..=600000")?;
        }
        crate::faults::parse_all(&self.sim.faults).map_err(|why| ConfigError::Invalid {
            key: "sim.faults".into(),
            why,
        })?;
        let rec = &self.record;
        range(
            "record.chunk_size_kib",
            rec.chunk_size_kib,
            4,
            1 << 20,
            "4..=1048576",
        )?;
        range(
            "record.pool_messages",
            rec.pool_messages,
            16,
            1 << 20,
            "16..=1048576",
        )?;
        range(
            "record.telemetry_every_frames",
            rec.telemetry_every_frames,
            1,
            1 << 20,
            "1..=1048576",
        )?;
        range(
            "record.cloud_every",
            rec.cloud_every,
            1,
            1_000_000,
            "1..=1000000",
        )?;
        if rec.compression != "zstd" && rec.compression != "none" {
            return Err(ConfigError::Invalid {
                key: "record.compression".into(),
                why: format!("\"{}\" is not zstd or none", rec.compression),
            });
        }
        range(
            "devices.imu_baud",
            self.devices.imu_baud,
            1200,
            4_000_000,
            "1200..=4000000",
        )?;
        let d = &self.devices;
        if d.can_transport != "socketcan" && d.can_transport != "slcan" {
            return Err(ConfigError::Invalid {
                key: "devices.can_transport".into(),
                why: format!("\"{}\" is not socketcan or slcan", d.can_transport),
            });
        }
        if !speleo_hal::slcan::BIT_RATES.contains(&d.can_bit_rate) {
            return Err(ConfigError::Invalid {
                key: "devices.can_bit_rate".into(),
                why: format!(
                    "{} bit/s is not a CAN bit rate an slcan adapter sets ({:?})",
                    d.can_bit_rate,
                    speleo_hal::slcan::BIT_RATES
                ),
            });
        }
        range(
            "devices.can_serial_baud",
            d.can_serial_baud,
            1200,
            4_000_000,
            "1200..=4000000",
        )?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_can_transport_and_its_bit_rate_are_checked() {
        let c = Config::from_toml("[devices]\ncan_transport = \"slcan\"\ncan_bit_rate = 500000\n")
            .expect("read");
        c.validate().expect("valid");
        let e = Config::from_toml("[devices]\ncan_transport = \"lin\"\n")
            .expect_err("not a transport")
            .to_string();
        assert!(
            e.contains("devices.can_transport") && e.contains("lin"),
            "{e}"
        );
        let e = Config::from_toml("[devices]\ncan_bit_rate = 83333\n")
            .expect_err("not an slcan rate")
            .to_string();
        assert!(
            e.contains("devices.can_bit_rate") && e.contains("83333"),
            "{e}"
        );
    }

    #[test]
    fn defaults_are_valid_and_round_trip() {
        let c = Config::default();
        c.validate().expect("valid");
        assert_eq!(Config::from_toml(&c.to_toml()).expect("parses"), c);
    }

    #[test]
    fn a_start_pose_is_read_and_a_non_finite_one_is_named() {
        let c = Config::from_toml("[sim]\nstart = [2.5, 2.3, 3.0, 90.0]\n").expect("read");
        assert_eq!(c.sim.start, Some(StartSpec::Pose([2.5, 2.3, 3.0, 90.0])));
        let c = Config::from_toml("[sim]\nstart = \"m50\"\n").expect("read");
        assert_eq!(c.sim.start, Some(StartSpec::Waypoint("m50".into())));
        let e = Config::from_toml("[sim]\nstart = [2.5, nan, 3.0, 0.0]\n").expect_err("refused");
        assert!(e.to_string().contains("sim.start"), "{e}");
        let e = Config::from_toml("[sim]\nstart = [2.5, 2.3]\n").expect_err("refused");
        assert!(e.to_string().contains("start"), "{e}");
    }

    #[test]
    fn a_lower_body_clearance_alone_is_valid_with_the_default_step() {
        // The default step (0.1) is 0.01 under a clearance of 0.11: valid,
        // although 0.1 as f32 is a hair over it.
        let c = Config::from_toml("[planner]\nground_clearance_m = 0.11\n").expect("read");
        assert_eq!(c.planner.nav.trav.max_step_m, 0.1);
        let e = Config::from_toml("[planner]\nground_clearance_m = 0.105\n").expect_err("refused");
        assert!(e.to_string().contains("planner.max_step_m"), "{e}");
    }

    #[test]
    fn unknown_keys_are_named() {
        let e = Config::from_toml("[executive]\nminor_frame_ms = 10\n").expect_err("refused");
        let m = e.to_string();
        assert!(m.contains("minor_frame_ms"), "{m}");
        let e = Config::from_toml("[sim]\nseed = 1\ncolour = 2\n").expect_err("refused");
        assert!(e.to_string().contains("colour"), "{e}");
        let e = Config::from_toml("[tasks.odometry]\nbudjet_us = 3\n").expect_err("refused");
        assert!(e.to_string().contains("budjet_us"), "{e}");
    }

    #[test]
    fn out_of_range_values_are_named() {
        let e = Config::from_toml("[executive]\nminor_frame_us = 5\n").expect_err("refused");
        assert!(e.to_string().contains("executive.minor_frame_us"), "{e}");
        let e = Config::from_toml("[tasks.control]\npolicy = \"panic\"\n").expect_err("refused");
        assert!(e.to_string().contains("tasks.control.policy"), "{e}");
        let e = Config::from_toml("[rover]\nwheel_radius_m = -1.0\n").expect_err("refused");
        assert!(e.to_string().contains("rover.wheel_radius_m"), "{e}");
        for share in ["1.5", "-0.1", "nan"] {
            let e = Config::from_toml(&format!("[slam]\nmin_surface_share = {share}\n"))
                .expect_err("refused");
            assert!(e.to_string().contains("slam.min_surface_share"), "{e}");
        }
        assert!(Config::from_toml("[slam]\nmin_surface_share = 0.0\n").is_ok());
    }
}

#[cfg(test)]
mod composed_tests;
