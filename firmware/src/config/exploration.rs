//! `[exploration]`: the exploration behaviour (section 2.4 of the paper)
//! that the planner task runs when enabled, instead of following a route.

use serde::{Deserialize, Serialize};

use super::{range, ConfigError};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExplorationConfig {
    /// Explore and come home (needs the planner), the default; off:
    /// follow the route (`speleo sim --route`).
    pub enabled: bool,
    /// Exploring ends after this much mission time, s; the return follows.
    pub time_limit_s: f64,
    /// Patches within this radius of where the rover has been are not
    /// candidates, m.
    pub coverage_radius_m: f64,
    /// Queries in a row without a candidate before the rover goes home.
    pub empty_queries_to_return: u32,
    /// After a traverse ends, the maps get this long to take in the last
    /// keyframes before the next query, s.
    pub settle_s: f64,
    /// Candidates nearer than this give too little progress, m.
    pub min_goal_distance_m: f64,
    /// Score weights: per m² of unexplored ground within 1 m, and per
    /// metre from `target` (when set).
    pub weight_unexplored: f64,
    pub weight_target: f64,
    pub target: Option<[f64; 2]>,
    /// Home is reached within this distance, m.
    pub home_tolerance_m: f64,
    /// A goal over a rock rising more than this under the body is refused
    /// before planning, m; 0: off (see
    /// `speleo_exploration::CandidateParams::max_rock_m`).
    pub max_goal_rock_m: f64,
    /// Exploring ends when the energy drawn and the way home's expected
    /// cost reach this, Wh; 0: no budget (the energy is still counted).
    pub energy_budget_wh: f64,
    /// The way home is expected to cost this many times what the way out
    /// cost a metre.
    pub energy_return_factor: f64,
    /// The rover's draw (`speleo_exploration::PowerModel`): always, W ...
    pub base_power_w: f64,
    /// ... the drives' efficiency, mechanical at the wheel over electrical ...
    pub drive_efficiency: f64,
    /// ... and their windings' heat, W per (N m)^2 of wheel torque.
    pub winding_loss_w_per_nm2: f64,
}

impl Default for ExplorationConfig {
    fn default() -> Self {
        let e = speleo_exploration::ExplorerParams::default();
        let c = speleo_exploration::CandidateParams::default();
        let m = speleo_exploration::PowerModel::default();
        ExplorationConfig {
            enabled: true,
            time_limit_s: e.time_limit_s,
            coverage_radius_m: e.coverage_radius_m,
            empty_queries_to_return: e.empty_queries_to_return,
            settle_s: 1.5,
            min_goal_distance_m: c.min_distance_m,
            weight_unexplored: c.weight_unexplored,
            weight_target: c.weight_target,
            target: None,
            home_tolerance_m: e.home_tolerance_m,
            max_goal_rock_m: c.max_rock_m,
            energy_budget_wh: e.energy_budget_wh,
            energy_return_factor: e.energy_return_factor,
            base_power_w: m.base_power_w,
            drive_efficiency: m.drive_efficiency,
            winding_loss_w_per_nm2: m.winding_loss_w_per_nm2,
        }
    }
}

impl ExplorationConfig {
    pub(super) fn validate(&self) -> Result<(), ConfigError> {
        let k = |s: &str| format!("exploration.{s}");
        range(&k("time_limit_s"), self.time_limit_s, 0.0, 1e7, "0..=1e7")?;
        range(
            &k("coverage_radius_m"),
            self.coverage_radius_m,
            0.0,
            50.0,
            "0..=50",
        )?;
        range(
            &k("empty_queries_to_return"),
            self.empty_queries_to_return,
            1,
            1000,
            "1..=1000",
        )?;
        range(&k("settle_s"), self.settle_s, 0.0, 60.0, "0..=60")?;
        range(
            &k("min_goal_distance_m"),
            self.min_goal_distance_m,
            0.0,
            100.0,
            "0..=100",
        )?;
        range(
            &k("weight_unexplored"),
            self.weight_unexplored,
            0.0,
            1e3,
            "0..=1000",
        )?;
        range(
            &k("weight_target"),
            self.weight_target,
            0.0,
            1e3,
            "0..=1000",
        )?;
        range(
            &k("max_goal_rock_m"),
            self.max_goal_rock_m,
            0.0,
            1.0,
            "0..=1",
        )?;
        range(
            &k("energy_budget_wh"),
            self.energy_budget_wh,
            0.0,
            1e6,
            "0..=1e6",
        )?;
        range(
            &k("energy_return_factor"),
            self.energy_return_factor,
            1.0,
            10.0,
            "1..=10",
        )?;
        range(&k("base_power_w"), self.base_power_w, 0.0, 1e4, "0..=1e4")?;
        range(
            &k("drive_efficiency"),
            self.drive_efficiency,
            0.05,
            1.0,
            "0.05..=1",
        )?;
        range(
            &k("winding_loss_w_per_nm2"),
            self.winding_loss_w_per_nm2,
            0.0,
            100.0,
            "0..=100",
        )?;
        range(
            &k("home_tolerance_m"),
            self.home_tolerance_m,
            0.05,
            10.0,
            "0.05..=10",
        )?;
        if self
            .target
            .is_some_and(|t| t.iter().any(|v| !v.is_finite()))
        {
            return Err(ConfigError::Invalid {
                key: k("target"),
                why: "must be finite numbers".into(),
            });
        }
        Ok(())
    }

    pub fn explorer_params(&self) -> speleo_exploration::ExplorerParams {
        speleo_exploration::ExplorerParams {
            time_limit_s: self.time_limit_s,
            coverage_radius_m: self.coverage_radius_m,
            empty_queries_to_return: self.empty_queries_to_return,
            home_tolerance_m: self.home_tolerance_m,
            energy_budget_wh: self.energy_budget_wh,
            energy_return_factor: self.energy_return_factor,
            power: self.power_model(),
            ..Default::default()
        }
    }

    pub fn power_model(&self) -> speleo_exploration::PowerModel {
        speleo_exploration::PowerModel {
            base_power_w: self.base_power_w,
            drive_efficiency: self.drive_efficiency,
            winding_loss_w_per_nm2: self.winding_loss_w_per_nm2,
        }
    }

    pub fn candidate_params(&self) -> speleo_exploration::CandidateParams {
        speleo_exploration::CandidateParams {
            min_distance_m: self.min_goal_distance_m,
            weight_unexplored: self.weight_unexplored,
            weight_target: self.weight_target,
            max_rock_m: self.max_goal_rock_m,
            ..Default::default()
        }
    }
}
