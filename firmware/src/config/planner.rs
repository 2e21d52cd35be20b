//! `[planner]`: the traversability graph and the anytime multi-level ARA*
//! planner run by the `planner` task over the serving MLS map.

use serde::{Deserialize, Serialize};

use super::{range, ConfigError, PlannerStepUnits};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlannerConfig {
    /// Plan (needs the maps).
    pub enabled: bool,
    /// Side of the square around the rover the graph is grown in, m.
    pub window_m: f64,
    /// Exploring, after a query that drove nothing (no candidate, or none
    /// reachable) the next grows its graph in a window half as large
    /// again, up to this side, m; a plan driven brings it back to
    /// `window_m`. The way to a garage ramp's foot lay outside 30 m from
    /// the far side of the level.
    pub window_max_m: f64,
    /// Most nodes the graph holds; the search's storage is this many
    /// nodes times the primitives' headings. The garage's levels fill
    /// 2^16 in most queries; at 2^18 (251 MB) its roof ramp's top entered
    /// the graph, but garage seed 1 took another course and was stranded
    /// on ramp 1→2's side (coverage 0.69) where at 2^16 it comes home.
    pub max_nodes: usize,
    /// The goal: this far ahead of the rover along the route, m.
    pub goal_ahead_m: f64,
    /// A new query this long after the last one began, s.
    pub replan_every_s: f64,
    /// A query that has not proven its plan optimal after this many
    /// expansions keeps its best plan and stops.
    pub max_expansions: u64,
    /// ARA*'s first inflation, and how much it falls after each solution.
    pub initial_eps: f64,
    pub eps_step: f64,
    /// Steepest support plane and highest step the rover drives.
    pub max_slope_deg: f64,
    pub max_step_m: f64,
    /// The body's underside over the ground: the map must show nothing
    /// between this height and the body's top along a path, m.
    pub ground_clearance_m: f64,
    /// Travel-time costs.
    pub forward_speed_mps: f64,
    pub backward_speed_mps: f64,
    pub turn_speed_rad_s: f64,
    /// The body's rectangle checked at every pose of a primitive.
    pub body_length_m: f64,
    pub body_width_m: f64,
    /// Extra cost near obstacles: travel time times `1 + weight x (1 - d /
    /// R)` (see the planner README); 0 plans for time alone.
    pub clearance_weight: f64,
    /// Extra cost over bumps under the body: travel time times `1 +
    /// weight x b^2`, `b` from 0 at 4 cm to 1 at the ground clearance (see
    /// the planner README); 0: off. At 10 a rock 0.1 m tall costs a path
    /// 6.6 times its travel time.
    pub bump_weight: f64,
    /// A node with a bump under the body higher than this (m over its
    /// support plane, as for `bump_weight`) is not passed, except near
    /// the start; 0: off. The map holds small boulders at about half
    /// their height (the planner README).
    pub max_bump_m: f64,
    /// Extra cost near a drop the map has seen (a ramp's open side, a
    /// ledge's rim): travel time times `1 + weight x (1 - d / reach)`,
    /// `d` the least distance from the path to the drop within
    /// `edge_reach_m` (see the planner README); 0: off. Off by default:
    /// at 2, the garage's rover no longer stranded on ramp 1's side (seed
    /// 2) but explored less in both seeds tried, and never left the floor
    /// in seed 1 (the planner README).
    pub edge_weight: f64,
    pub edge_reach_m: f64,
    /// A primitive whose body rectangle covers this many cells of a drop
    /// the map has seen (a ramp's open side) is refused: the
    /// traversability map's 0.4 m footprint lies inside the body's
    /// corners (see the planner README); 0: off. Off by default: at 3,
    /// garage seeds 1 and 3 stalled 2.5 m up the first ramp.
    pub body_drop_cells: u32,
    /// A drop at least `deep_drop_m` deep seen within this distance of a
    /// node blocks it (the traversability README); 0: the footprint's own
    /// drop check only.
    pub drop_clearance_m: f64,
    pub deep_drop_m: f64,
    /// An SBPL `.mprim` file at the map's resolution; empty: the
    /// generated set for the rover (`speleo primitives`).
    pub mprim: String,
    /// Work units of one step in each phase (`[planner.step_units]`).
    pub step_units: PlannerStepUnits,
}

impl Default for PlannerConfig {
    /// The navigator's defaults (`NavigatorParams::default`).
    fn default() -> Self {
        let n = speleo_navigator::NavigatorParams::default();
        let (s, t) = (&n.surface, &n.trav);
        PlannerConfig {
            enabled: true,
            window_m: n.window_m,
            window_max_m: n.window_max_m,
            max_nodes: t.max_nodes,
            goal_ahead_m: n.goal_ahead_m,
            replan_every_s: n.replan_every_s,
            max_expansions: n.max_expansions,
            initial_eps: n.initial_eps,
            eps_step: n.eps_step,
            max_slope_deg: t.max_slope_deg,
            max_step_m: decimal(t.max_step_m),
            ground_clearance_m: decimal(t.ground_clearance_m),
            forward_speed_mps: s.forward_speed_mps,
            backward_speed_mps: s.backward_speed_mps,
            turn_speed_rad_s: s.turn_speed_rad_s,
            body_length_m: s.body_length_m,
            body_width_m: s.body_width_m,
            clearance_weight: s.clearance_weight,
            bump_weight: s.bump_weight,
            max_bump_m: s.max_bump_m,
            edge_weight: s.edge_weight,
            edge_reach_m: s.edge_reach_m,
            body_drop_cells: s.body_drop_cells,
            drop_clearance_m: t.drop_clearance_m,
            deep_drop_m: decimal(t.deep_drop_m),
            mprim: String::new(),
            step_units: PlannerStepUnits::default(),
        }
    }
}

/// A length the traversability map keeps as `f32`, as the decimal it was
/// written as (0.1, not 0.10000000149): defaults that print and compare
/// as a user would write them.
fn decimal(v: f32) -> f64 {
    (v as f64 * 1e6).round() / 1e6
}

impl PlannerConfig {
    pub(super) fn validate(&self, mls_resolution_m: f64) -> Result<(), ConfigError> {
        range("planner.window_m", self.window_m, 2.0, 500.0, "2..=500")?;
        range(
            "planner.window_max_m",
            self.window_max_m,
            self.window_m,
            500.0,
            "window_m..=500",
        )?;
        let cells = (self.window_max_m / mls_resolution_m + 2.0).powi(2);
        if cells > 64e6 {
            return Err(ConfigError::Invalid {
                key: "planner.window_max_m".into(),
                why: format!("{cells:.0} cells of maps.mls_resolution_m: at most 64 M"),
            });
        }
        range(
            "planner.max_nodes",
            self.max_nodes,
            16,
            1 << 22,
            "16..=4194304",
        )?;
        range(
            "planner.goal_ahead_m",
            self.goal_ahead_m,
            0.5,
            self.window_m / 2.0,
            "0.5..=window_m / 2",
        )?;
        range(
            "planner.replan_every_s",
            self.replan_every_s,
            0.1,
            3600.0,
            "0.1..=3600",
        )?;
        range(
            "planner.max_expansions",
            self.max_expansions,
            1,
            u32::MAX as u64,
            "1..=4294967295",
        )?;
        range(
            "planner.initial_eps",
            self.initial_eps,
            1.0,
            100.0,
            "1..=100",
        )?;
        range(
            "planner.eps_step",
            self.eps_step,
            0.001,
            100.0,
            "0.001..=100",
        )?;
        range(
            "planner.max_slope_deg",
            self.max_slope_deg,
            1.0,
            80.0,
            "1..=80",
        )?;
        // Under the body's top (`TravParams::robot_height_m`, 0.7 m).
        range(
            "planner.ground_clearance_m",
            self.ground_clearance_m,
            0.02,
            0.69,
            "0.02..=0.69",
        )?;
        // The bound is a difference of decimals: a micrometre of slack.
        range(
            "planner.max_step_m",
            self.max_step_m,
            0.01,
            self.ground_clearance_m - 0.01 + 1e-6,
            "0.01..=ground_clearance_m - 0.01",
        )?;
        for (k, v) in [
            ("planner.forward_speed_mps", self.forward_speed_mps),
            ("planner.backward_speed_mps", self.backward_speed_mps),
            ("planner.turn_speed_rad_s", self.turn_speed_rad_s),
            ("planner.body_length_m", self.body_length_m),
            ("planner.body_width_m", self.body_width_m),
        ] {
            range(k, v, 0.01, 10.0, "0.01..=10")?;
        }
        for (k, v) in [
            ("planner.clearance_weight", self.clearance_weight),
            ("planner.bump_weight", self.bump_weight),
            ("planner.edge_weight", self.edge_weight),
        ] {
            range(k, v, 0.0, 100.0, "0..=100")?;
        }
        // Over the ground clearance the body band refuses the node anyway.
        range(
            "planner.max_bump_m",
            self.max_bump_m,
            0.0,
            self.ground_clearance_m,
            "0..=ground_clearance_m",
        )?;
        range(
            "planner.drop_clearance_m",
            self.drop_clearance_m,
            0.0,
            5.0,
            "0..=5",
        )?;
        range(
            "planner.deep_drop_m",
            self.deep_drop_m,
            0.01,
            100.0,
            "0.01..=100",
        )?;
        range(
            "planner.body_drop_cells",
            self.body_drop_cells,
            0,
            1000,
            "0..=1000",
        )?;
        // With the term on, each node's cell scan widens by this reach:
        // bounded, so a preparation unit's time is.
        range(
            "planner.edge_reach_m",
            self.edge_reach_m,
            0.1,
            2.0,
            "0.1..=2",
        )?;
        self.step_units.validate()
    }

    pub fn trav_params(&self) -> speleo_traversability::TravParams {
        speleo_traversability::TravParams {
            max_slope_deg: self.max_slope_deg,
            max_step_m: self.max_step_m as f32,
            ground_clearance_m: self.ground_clearance_m as f32,
            max_nodes: self.max_nodes,
            drop_clearance_m: self.drop_clearance_m,
            deep_drop_m: self.deep_drop_m as f32,
            ..speleo_traversability::TravParams::default()
        }
    }

    pub fn surface_params(&self) -> speleo_planner::surface::SurfaceParams {
        speleo_planner::surface::SurfaceParams {
            forward_speed_mps: self.forward_speed_mps,
            backward_speed_mps: self.backward_speed_mps,
            turn_speed_rad_s: self.turn_speed_rad_s,
            body_length_m: self.body_length_m,
            body_width_m: self.body_width_m,
            clearance_weight: self.clearance_weight,
            bump_weight: self.bump_weight,
            max_bump_m: self.max_bump_m,
            edge_weight: self.edge_weight,
            edge_reach_m: self.edge_reach_m,
            body_drop_cells: self.body_drop_cells,
            ..speleo_planner::surface::SurfaceParams::default()
        }
    }

    /// Cells of the lattice's map table for the largest growth window at
    /// `resolution_m`.
    /// The navigator's settings.
    pub fn navigator_params(&self) -> speleo_navigator::NavigatorParams {
        speleo_navigator::NavigatorParams {
            window_m: self.window_m,
            window_max_m: self.window_max_m,
            goal_ahead_m: self.goal_ahead_m,
            replan_every_s: self.replan_every_s,
            max_expansions: self.max_expansions,
            initial_eps: self.initial_eps,
            eps_step: self.eps_step,
            trav: self.trav_params(),
            surface: self.surface_params(),
        }
    }

    pub fn window_cells(&self, resolution_m: f64) -> usize {
        speleo_planner::surface::grid_cells_for_window(
            self.window_max_m,
            resolution_m,
            &self.surface_params(),
        )
    }
}
