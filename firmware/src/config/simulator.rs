//! `[simulator]`: the internal simulator that drives every exploration
//! plan on the rover's own map before the rover drives it.

use serde::{Deserialize, Serialize};

use super::{range, ConfigError};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimulatorConfig {
    /// Validate each exploration plan in simulation first (the default):
    /// a plan the simulated rover does not drive to its goal is refused
    /// and the next goal tried. Off: plans are driven as planned.
    pub enabled: bool,
    /// TSDF voxel side, m, and the most 8^3-voxel blocks (4 KiB each).
    pub voxel_m: f64,
    pub max_blocks: usize,
    /// The simulated world is the box around the plan grown by this, m.
    pub margin_m: f64,
    /// Physics step, s.
    pub dt_s: f64,
    /// The goal is reached within this distance, m.
    pub goal_tolerance_m: f64,
    /// A tilt over this is a tip-over, deg (or over `control.max_tilt_deg`,
    /// where the safety monitor would stop the rover, when that is lower).
    pub tip_over_deg: f64,
    /// Commanded this long without 0.1 m of progress: stuck, s.
    pub stuck_after_s: f64,
    /// The world is made of the newest this many keyframes near the plan
    /// (older passes may not agree with them before SLAM closes the loop).
    pub newest_keyframes: usize,
    /// Work units a frame done on a core of its own (a worker thread the
    /// planner task lends the validation to and takes it back from the
    /// next frame): everything but the clouds' integration. A physics
    /// step is 6 units, so 120 drives the simulated rover 20 times faster
    /// than real time at 10 ms steps (the default). 0: all the work in
    /// the planner's own window (`planner.step_units.validate` a frame),
    /// 2x real time, for a computer with one core.
    pub worker_units: u32,
    /// Write every validation's inputs and verdict to this folder as
    /// validation-NNNN.case, for `speleo validate` (`speleo sim
    /// --dump-validations`). A debugging aid: files written from the
    /// planner task. Off by default.
    pub dump_dir: Option<std::path::PathBuf>,
    /// Start the simulated rover pitched and rolled as SLAM says it
    /// stands, not level (see `speleo_simulator::SimulatorParams`). Off by
    /// default for now.
    pub start_tilted: bool,
    /// With `start_tilted` off, a rover tilted more than this still starts
    /// as it stands, deg (90: never).
    pub start_tilted_over_deg: f64,
    /// An exploring plan that takes the rover down more than this is
    /// driven back up too, backward to its start, and refused when that
    /// fails (`no_way_back`), m; 0: never.
    pub way_back_drop_m: f64,
    /// A plan that ends with a wheel's hub over no ground within its
    /// radius and this much more is refused (`overhang`), m; 0: never.
    pub overhang_depth_m: f64,
}

impl Default for SimulatorConfig {
    fn default() -> Self {
        let p = speleo_simulator::SimulatorParams::default();
        SimulatorConfig {
            enabled: true,
            voxel_m: p.voxel_m,
            max_blocks: p.max_blocks,
            margin_m: p.margin_m,
            dt_s: p.dt_s,
            goal_tolerance_m: p.goal_tolerance_m,
            tip_over_deg: p.tip_over_deg,
            stuck_after_s: p.stuck_after_s,
            newest_keyframes: p.newest_keyframes,
            worker_units: 120,
            dump_dir: None,
            start_tilted: p.start_tilted,
            start_tilted_over_deg: p.start_tilted_over_deg,
            way_back_drop_m: p.way_back_drop_m,
            overhang_depth_m: p.overhang_depth_m,
        }
    }
}

impl SimulatorConfig {
    pub(super) fn validate(&self) -> Result<(), ConfigError> {
        let k = |s: &str| format!("simulator.{s}");
        range(&k("voxel_m"), self.voxel_m, 0.01, 0.5, "0.01..=0.5")?;
        range(
            &k("max_blocks"),
            self.max_blocks,
            64,
            1 << 20,
            "64..=1048576",
        )?;
        range(&k("margin_m"), self.margin_m, 0.5, 20.0, "0.5..=20")?;
        range(&k("dt_s"), self.dt_s, 0.0005, 0.01, "0.0005..=0.01")?;
        range(
            &k("goal_tolerance_m"),
            self.goal_tolerance_m,
            0.05,
            5.0,
            "0.05..=5",
        )?;
        range(&k("tip_over_deg"), self.tip_over_deg, 5.0, 90.0, "5..=90")?;
        range(
            &k("stuck_after_s"),
            self.stuck_after_s,
            0.5,
            120.0,
            "0.5..=120",
        )?;
        range(
            &k("newest_keyframes"),
            self.newest_keyframes,
            1,
            100_000,
            "1..=100000",
        )?;
        range(
            &k("start_tilted_over_deg"),
            self.start_tilted_over_deg,
            0.0,
            90.0,
            "0..=90",
        )?;
        range(
            &k("way_back_drop_m"),
            self.way_back_drop_m,
            0.0,
            100.0,
            "0..=100",
        )?;
        range(
            &k("overhang_depth_m"),
            self.overhang_depth_m,
            0.0,
            10.0,
            "0..=10",
        )?;
        range(&k("worker_units"), self.worker_units, 0, 4096, "0..=4096")?;
        Ok(())
    }
}
