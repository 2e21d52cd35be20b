//! The topology: every on-board task in execution order with its schedule
//! (rate group, budget, overrun policy, safe mode), the mailboxes it
//! writes and reads, what it does, and how it is built from the
//! configuration. The configuration's `[tasks.NAME]` tables override the
//! schedule (`schedule_table.rs`); `docs/architecture.md`'s task table
//! is generated from this one and `firmware/tests/wiring.rs` checks both
//! against the tasks' code. Adding a task: `docs/adding-a-task.md`.

pub mod control;
pub mod drive_driver;
pub mod drive_output;
pub mod health;
pub mod imu_driver;
pub mod io;
pub mod lidar_driver;
pub mod maps;
pub mod odometry;
pub mod planner;
pub mod recorder;
pub mod slam;

use std::cell::RefCell;

use speleo_hal::Hardware;
use speleo_scheduler::OverrunPolicy::{self, Degrade, ReuseLast, SafeMode, Skip};
use speleo_scheduler::{AnytimeSpec, RateGroup, Task, TaskSpec, MAX_TASKS};

use crate::bus::Bus;
use crate::config::{Config, MapsConfig, MAX_STEP_UNITS};
use crate::params;
use crate::record::RecorderTap;

/// One task: its schedule, its wiring and its purpose.
#[derive(Clone, Copy, Debug)]
pub struct Node {
    /// Its name in the schedule, in `[tasks.NAME]`, its file
    /// (`NAME.rs` beside this one) and the reports.
    pub task: &'static str,
    pub rate: RateGroup,
    /// The budget of one run (an anytime task's: of one step), us.
    pub budget_us: u32,
    pub policy: OverrunPolicy,
    /// Runs in the safe schedule too.
    pub safe: bool,
    /// An anytime task's steps a frame, work quantum and window.
    pub anytime: Option<AnytimeSpec>,
    /// The bus fields it writes (and may read too)...
    pub writes: &'static [&'static str],
    /// ...and those it only reads.
    pub reads: &'static [&'static str],
    /// What it does, in a line.
    pub does: &'static str,
}

impl Node {
    /// The scheduler's entry for this task, before the configuration's
    /// overrides.
    pub fn spec(&self) -> TaskSpec {
        let spec = match self.anytime {
            Some(a) => TaskSpec::anytime(self.task, self.rate, self.budget_us, self.policy, a),
            None => TaskSpec::periodic(self.task, self.rate, self.budget_us, self.policy),
        };
        if self.safe {
            spec.safe()
        } else {
            spec
        }
    }
}

const EVERY: RateGroup = RateGroup::EVERY_FRAME;

/// The most work units of one planner step: each phase does its own
/// `planner.step_units` (calibrated with `speleo wcet --calibrate`), capped
/// by this quantum.
pub const PLANNER_QUANTUM: u32 = MAX_STEP_UNITS;

/// Every task, in the order they run within a frame.
#[rustfmt::skip]
pub const TOPOLOGY: [Node; 12] = [
    // Moves the frame's bytes between the devices and the bus (max
    // ~50 us measured in sim).
    Node { task: "io", rate: EVERY, budget_us: 400, policy: Skip, safe: true, anytime: None,
        writes: &["raw", "counters"],
        reads: &["can_tx", "imu_tx"],
        does: "brings the hardware to the frame time, sends last frame's CAN frames and Xbus messages, collects every raw input into the frame's arena" },
    // ~18 packets (6,700 points) a frame, decoded at ~90 M points/s; once
    // a revolution (~70k points) is handed over: ~0.2 ms more.
    Node { task: "lidar_driver", rate: EVERY, budget_us: 1_000, policy: Skip, safe: true, anytime: None,
        writes: &["cloud", "lidar"],
        reads: &["raw"],
        does: "HDL-32E packets -> revolutions (recycled point buffers), position packets" },
    Node { task: "imu_driver", rate: EVERY, budget_us: 300, policy: Skip, safe: true, anytime: None,
        writes: &["imu", "imu_tx", "imu_config", "counters"],
        reads: &["raw"],
        does: "MTi configuration exchange; Xbus stream -> MTData2 samples (ring of 32)" },
    Node { task: "drive_driver", rate: EVERY, budget_us: 300, policy: Skip, safe: true, anytime: None,
        writes: &["drives", "counters"],
        reads: &["raw"],
        does: "CAN frames -> CANopen events (heartbeats, PDOs, EMCY, SDO answers) -> what is known of each drive" },
    // Also in safe mode: a stopped rover keeps knowing where it is, and
    // the health task keeps seeing its wheels.
    Node { task: "odometry", rate: EVERY, budget_us: 300, policy: ReuseLast, safe: true, anytime: None,
        writes: &["odom", "odom_history", "odom_counters", "counters"],
        reads: &["imu", "drives"],
        does: "IMU attitude + wheel travel -> pose in the odom frame, history for deskewing" },
    // One bounded unit of keyframe work a frame (a part of a cloud's
    // preparation or of a GICP pass, the insertion, the solver's
    // analysis, a slice of factors of an LM iteration or its
    // factorisation).
    Node { task: "slam", rate: EVERY, budget_us: 2_000, policy: Skip, safe: false,
        anytime: Some(AnytimeSpec { quantum: 1, steps: 1, window_us: 2_000 }),
        writes: &["slam", "keyframe_clouds"],
        reads: &["cloud", "odom", "odom_history"],
        does: "graph SLAM: deskew, GICP against the submap, keyframes, loop closures, pose-graph optimisation, one bounded unit a frame" },
    // The multi-level surface map: one part of a keyframe's cloud
    // (maps.points_per_step points, ~0.4 ms) in the even frames, where
    // control does not run and 0.9 ms are free.
    Node { task: "maps", rate: RateGroup::new(2, 0), budget_us: 900, policy: Skip, safe: false,
        anytime: Some(AnytimeSpec { quantum: 1, steps: 1, window_us: 900 }),
        writes: &["surface"],
        reads: &["keyframe_clouds"],
        does: "the multi-level surface map from the keyframes' clouds, a part of a cloud a step" },
    // One phase's quantum a frame (graph nodes grown, lattice units
    // prepared, or ARA* expansions); the window holds the steps' p99.9
    // with another process busy on the other core.
    Node { task: "planner", rate: EVERY, budget_us: 1_500, policy: Skip, safe: false,
        anytime: Some(AnytimeSpec { quantum: PLANNER_QUANTUM, steps: 1, window_us: 1_500 }),
        writes: &["plan", "exploration"],
        reads: &["slam", "surface", "command", "drives", "keyframe_clouds"],
        does: "traversability graph, start and goal, ARA* over motion primitives, the internal simulation of each plan, exploration's goals and recovery" },
    // 50 Hz path following, in the odd frames.
    Node { task: "control", rate: RateGroup::new(2, 1), budget_us: 500, policy: Degrade, safe: false, anytime: None,
        writes: &["command"],
        reads: &["plan", "slam", "surface"],
        does: "pure pursuit -> body command -> wheel speeds; the safety monitor's stops" },
    Node { task: "drive_output", rate: EVERY, budget_us: 200, policy: SafeMode, safe: true, anytime: None,
        writes: &["can_tx", "drive_stop"],
        reads: &["command", "drives"],
        does: "drive supervisor: bring-up (SDO profile velocity mode, NMT start), CiA 402 enable, target velocities, SYNC; zero for every wheel in safe mode, on stale commands, a lost heartbeat or a fault" },
    // 10 Hz, offset to spread the load.
    Node { task: "health", rate: RateGroup::new(10, 5), budget_us: 200, policy: Skip, safe: true, anytime: None,
        writes: &["health", "safe_mode_request", "recovery_ready"],
        reads: &["drives", "drive_stop", "imu", "lidar", "odom_counters", "counters", "timing"],
        does: "device freshness, drive faults, wheel disagreement, overrun storms; requests the safe schedule and the way back" },
    // Encodes the frame's messages (CPU p99.9 < 1 ms); the writer thread compresses them.
    Node { task: "recorder", rate: EVERY, budget_us: 1_900, policy: Degrade, safe: true, anytime: None,
        writes: &[],
        reads: &["raw", "imu", "cloud", "drives", "drive_stop", "odom", "slam", "plan", "command", "can_tx", "imu_tx", "imu_config", "health", "counters"],
        does: "taps every mailbox and records what is new to MCAP" },
];

/// The mission loop's own wiring between frames: it switches schedules on
/// the health task's request and keeps the timing counters.
pub const EXECUTIVE_WRITES: &[&str] = &["timing", "recovery_ready"];
/// What the mission loop reads.
pub const EXECUTIVE_READS: &[&str] = &["safe_mode_request"];

/// Task names in execution order.
pub const TASKS: [&str; TOPOLOGY.len()] = names();

const fn names() -> [&'static str; TOPOLOGY.len()] {
    let mut out = [""; TOPOLOGY.len()];
    let mut i = 0;
    while i < TOPOLOGY.len() {
        out[i] = TOPOLOGY[i].task;
        i += 1;
    }
    out
}

/// Why the tasks could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("maps: {0}")]
    Maps(#[from] speleo_mapping::ParamsError),
    #[error("planner: {0}")]
    Planner(String),
    #[error("lidar.calibration: {0}")]
    Calibration(#[from] speleo_hal::hdl32e::calib::CalibError),
}

/// Every task of [`TOPOLOGY`], built.
pub struct Tasks<'r, 'h> {
    pub io: io::IoTask<'r, 'h>,
    pub lidar_driver: lidar_driver::LidarDriver,
    pub imu_driver: imu_driver::ImuDriver,
    pub drive_driver: drive_driver::DriveDriver,
    pub odometry: odometry::OdometryTask,
    pub slam: slam::SlamTask,
    pub maps: maps::MapsTask,
    pub planner: planner::PlannerTask,
    pub control: control::ControlTask,
    pub drive_output: drive_output::DriveOutput,
    pub health: health::HealthTask,
    pub recorder: recorder::RecorderTask<'r>,
}

impl<'r, 'h> Tasks<'r, 'h> {
    /// Every task as `cfg` describes it, on hardware `hw`, recording
    /// through `tap`; the bus's keyframe and map stores sized for them.
    pub fn build(
        cfg: &Config,
        bus: &mut Bus,
        hw: &'r RefCell<&'h mut dyn Hardware>,
        tap: &'r RefCell<RecorderTap>,
    ) -> Result<Self, BuildError> {
        let maps_on = cfg.maps.enabled && cfg.slam.enabled;
        let planner_on = maps_on && cfg.planner.enabled;
        let mut slam = slam::SlamTask::new(
            cfg.slam.params(),
            cfg.slam.enabled,
            params::mount_pose(cfg),
            cfg.lidar.max_points_per_frame as usize,
        );
        if let Some(f) = &cfg.sim.false_loop_closure {
            slam.inject_false_loop(f.clone());
        }
        let kf_capacity = cfg.slam.params.keyframe_capacity;
        let maps = if maps_on {
            bus.keyframe_clouds =
                speleo_mapping::KeyframeClouds::new(kf_capacity, cfg.maps.keyframe_points);
            slam = slam.with_maps(cfg.maps.range_m, cfg.maps.keyframe_points);
            bus.surface = speleo_mapping::SurfaceMaps::new(cfg.maps.mls_params())?;
            let mut t = maps::MapsTask::new(&cfg.maps, kf_capacity);
            t.builder = t.builder.with_sensor_at(cfg.lidar.mount_xyz);
            if let Some(g) = params::expected_ground(cfg)? {
                t.builder = t.builder.with_expected_ground(g);
            }
            t
        } else {
            // Idle: nothing ever reaches the keyframe clouds.
            let idle = MapsConfig {
                mls_max_cells: 1,
                ..cfg.maps.clone()
            };
            maps::MapsTask::new(&idle, 0)
        };
        let exploring = planner_on && cfg.exploration.enabled;
        Ok(Tasks {
            io: io::IoTask::new(hw),
            lidar_driver: lidar_driver::LidarDriver::from_config(cfg)?,
            // 100 Hz outputs; 100 ms for each acknowledgement, 5 tries.
            imu_driver: imu_driver::ImuDriver::new(100, 100_000_000, 5, cfg.devices.imu_baud),
            drive_driver: drive_driver::DriveDriver::default(),
            odometry: odometry::OdometryTask::new(params::odometry(cfg)),
            slam,
            maps,
            planner: planner::PlannerTask::from_config(cfg, planner_on)
                .map_err(BuildError::Planner)?,
            control: control::ControlTask::new(params::driver(cfg, exploring)),
            drive_output: drive_output::DriveOutput::new(params::supervisor(cfg)),
            health: health::HealthTask::new(params::health(cfg)),
            recorder: recorder::RecorderTask::new(
                tap,
                cfg.control.path.clone(),
                cfg.control.looped,
                cfg.lidar.mount_xyz,
                cfg.lidar.mount_rpy_deg,
            )
            .with_cloud_every(cfg.record.cloud_every),
        })
    }

    /// The tasks in [`TOPOLOGY`]'s order, for the executive.
    pub fn in_order(&mut self) -> heapless::Vec<&mut dyn Task<Bus>, MAX_TASKS> {
        let all: [&mut dyn Task<Bus>; TOPOLOGY.len()] = [
            &mut self.io,
            &mut self.lidar_driver,
            &mut self.imu_driver,
            &mut self.drive_driver,
            &mut self.odometry,
            &mut self.slam,
            &mut self.maps,
            &mut self.planner,
            &mut self.control,
            &mut self.drive_output,
            &mut self.health,
            &mut self.recorder,
        ];
        let mut v = heapless::Vec::new();
        for t in all {
            let _ = v.push(t);
        }
        v
    }
}

/// The context of frame `frame` of 10 ms frames in nominal mode, for task
/// tests.
#[cfg(test)]
pub(crate) fn test_context(frame: u64) -> speleo_scheduler::Context {
    speleo_scheduler::Context {
        frame,
        time_ns: frame * 10_000_000,
        minor_frame_ns: 10_000_000,
        mode: speleo_scheduler::Mode::Nominal,
        degraded: false,
    }
}
