//! The report's `exploration` section: what the exploration did, the area
//! it mapped, and, in simulation, how much of the world's reachable floor
//! that is, how far from its start the rover ended, how far it drove and
//! how often its chassis struck the world (ground truth).

use std::collections::{BTreeMap, HashMap};

use serde::Serialize;
use speleo_control::StopReason;
use speleo_mapping::mls::MlsMap;
use speleo_traversability::{TravMap, TravParams};

use crate::simulator_host::SimulatorWorker;
use speleo_control::ControlCounters;
use speleo_navigator::Exploration;

#[derive(Clone, Debug, Default, Serialize)]
pub struct ExplorationFigures {
    /// `exploring`, `returning` or `finished`, and why the return began
    /// (`explored`: nothing reachable was left; `time_limit`; `energy`:
    /// what was left of the budget was what the way home needs).
    pub state: String,
    pub return_reason: Option<String>,
    pub returned_home: bool,
    /// Drivable ground of the final map reachable from home or from where
    /// the rover went (its keyframes and its last pose), m^2.
    pub explored_area_m2: f64,
    /// Simulation only: the world's floor reachable from the start (its
    /// traversability graph on the world's own surface), the fraction of
    /// it that the explored area covers, the end's distance from the
    /// start, the distance driven and the chassis' strikes.
    pub reachable_floor_m2: Option<f64>,
    pub coverage_fraction: Option<f64>,
    pub home_error_m: Option<f64>,
    pub distance_m: Option<f64>,
    /// Simulation only: the farthest the true track went from the start,
    /// m, and where the rover ended (world frame).
    pub reach_m: Option<f64>,
    pub end_position: Option<[f64; 3]>,
    pub collisions: Option<u64>,
    /// Simulation only: the rover's falls (it sank faster than 3 m/s,
    /// about half a metre of free fall), the worst one's height, m, and
    /// whether one (1 m or more) wrecked it, leaving it where it struck.
    pub falls: Option<u64>,
    pub worst_fall_m: Option<f64>,
    pub wrecked: Option<bool>,
    /// Highest and lowest the rover went over and under home (SLAM), m:
    /// the levels reached in a multi-level world.
    pub climbed_m: f64,
    pub descended_m: f64,
    /// Goals planned to (candidates and points on the way home), those
    /// with no path, those whose plan the internal simulator passed and
    /// refused, and plans driven.
    pub goals_attempted: u64,
    pub goals_unreachable: u64,
    /// Goals refused for a rock under the body there (turning on the spot
    /// over it wedges the rover).
    pub goals_on_rocks: u64,
    pub goals_validated: u64,
    pub goals_rejected_by_sim: u64,
    pub plans_executed: u64,
    pub plans_completed: u64,
    /// Queries whose goals all failed the simulation and that drove the
    /// part of a refused plan the simulated rover drove well (up to a
    /// metre short of where it failed).
    pub partial_plans: u64,
    /// Going home without a plan from where the rover stood: drives back
    /// along its own track.
    pub retraces: u64,
    /// Retraces the internal simulation refused (not driven).
    pub retraces_refused: u64,
    /// Returns home that found something to explore on the way.
    pub resumes: u64,
    /// Stuck stops the rover backed out of; each place became an obstacle.
    pub backed_out: u64,
    /// Back-outs the internal simulation refused (tilted past the limit).
    pub back_outs_refused: u64,
    /// Times nothing was left but barred places, which were forgotten once.
    pub second_looks: u64,
    /// Places the rover slid back or stalled climbing, pitched 17 degrees
    /// or more: the ground up from each is barred for exploring.
    pub slides: u64,
    /// Rims the safety monitor stopped the rover at: no path goes within
    /// 0.5 m of each from then on.
    pub rims: u64,
    /// Candidate scans, and those that found nothing.
    pub scans: u64,
    pub scans_empty: u64,
    pub safety_stops: BTreeMap<String, u64>,
    /// Area within the coverage radius of the rover's track, m^2.
    pub covered_area_m2: f64,
    /// The energy drawn, from the drives' velocities and torques and the
    /// base draw, Wh; the budget (0: none); how long some drive reported
    /// no torque, s (its wheel's draw is missing for that long).
    pub energy_used_wh: f64,
    pub energy_budget_wh: f64,
    pub energy_unmeasured_s: f64,
}

/// The on-board figures.
pub fn onboard(e: &Exploration, c: &ControlCounters) -> ExplorationFigures {
    use speleo_exploration::{ExplorerPhase, ReturnReason};
    let reason = |r: ReturnReason| match r {
        ReturnReason::Explored => "explored".to_string(),
        ReturnReason::TimeLimit => "time_limit".to_string(),
        ReturnReason::Energy => "energy".to_string(),
    };
    let (state, return_reason) = match e.phase() {
        ExplorerPhase::Exploring => ("exploring", None),
        ExplorerPhase::Returning(r) => ("returning", Some(reason(r))),
        ExplorerPhase::Finished(r) => ("finished", Some(reason(r))),
        ExplorerPhase::Stranded => ("stranded", None),
    };
    ExplorationFigures {
        state: state.into(),
        return_reason,
        returned_home: matches!(e.phase(), ExplorerPhase::Finished(_)),
        goals_attempted: e.counters.goals_attempted,
        goals_unreachable: e.counters.goals_unreachable,
        goals_on_rocks: e.counters.goals_on_rocks,
        goals_validated: e.counters.validated,
        goals_rejected_by_sim: e.counters.rejected_by_sim,
        plans_executed: e.counters.plans_executed,
        plans_completed: c.plans_completed,
        partial_plans: e.counters.partial_plans,
        retraces: e.counters.retraces,
        retraces_refused: e.counters.retraces_refused,
        resumes: e.counters.resumes,
        backed_out: e.counters.backed_out,
        back_outs_refused: e.counters.back_outs_refused,
        second_looks: e.counters.second_looks,
        slides: e.counters.slides,
        rims: e.counters.rims,
        climbed_m: e.climbed_m,
        descended_m: e.descended_m,
        scans: e.counters.scans,
        scans_empty: e.counters.scans_empty,
        safety_stops: StopReason::ALL
            .into_iter()
            .map(|r| (r.name().to_string(), c.stops[r as usize - 1]))
            .collect(),
        covered_area_m2: e.explorer.coverage().area_m2(),
        energy_used_wh: e.energy.used_wh(),
        energy_budget_wh: e.explorer.params().energy_budget_wh,
        energy_unmeasured_s: e.energy.unmeasured_s(),
        ..Default::default()
    }
}

/// The traversability graph over `mls` from the ground under any of
/// `starts`, with room for any map a mission makes; `None` when there is
/// no ground under any.
pub fn reachable(mls: &MlsMap, starts: &[[f64; 3]], params: &TravParams) -> Option<TravMap> {
    let mut t = TravMap::new(TravParams {
        max_nodes: 1 << 22,
        ..params.clone()
    })
    .ok()?;
    t.build_from(mls, starts).ok()?;
    Some(t)
}

/// Drivable area of a graph, m^2.
pub fn drivable_area_m2(t: &TravMap) -> f64 {
    let res = t.resolution();
    t.nodes().iter().filter(|n| n.class.is_drivable()).count() as f64 * res * res
}

/// How much of `truth`'s drivable ground lies within `near_m` (in x and y,
/// and half a metre in height) of `explored`'s, whose positions go to the
/// world frame through `to_world`.
pub fn coverage_fraction(
    truth: &TravMap,
    explored: &TravMap,
    to_world: impl Fn([f64; 3]) -> [f64; 3],
    near_m: f64,
) -> f64 {
    let res = truth.resolution();
    let cell = |v: f64| (v / res).floor() as i32;
    let r = (near_m / res).round() as i32;
    let mut seen: HashMap<(i32, i32), Vec<f32>> = HashMap::new();
    for n in explored.nodes().iter().filter(|n| n.class.is_drivable()) {
        let p = to_world(explored.position(n));
        let (ix, iy) = (cell(p[0]), cell(p[1]));
        for dy in -r..=r {
            for dx in -r..=r {
                seen.entry((ix + dx, iy + dy))
                    .or_default()
                    .push(p[2] as f32);
            }
        }
    }
    let drivable: Vec<_> = truth
        .nodes()
        .iter()
        .filter(|n| n.class.is_drivable())
        .collect();
    if drivable.is_empty() {
        return 0.0;
    }
    let covered = drivable
        .iter()
        .filter(|n| {
            seen.get(&(n.ix, n.iy))
                .is_some_and(|zs| zs.iter().any(|z| (z - n.ground_z).abs() < 0.5))
        })
        .count();
    covered as f64 / drivable.len() as f64
}

/// The report's `internal_sim` section: the plans driven in the internal
/// simulator before the rover drove them, and how well the simulation
/// predicted the real traverse (RMSE of the positions at equal times since
/// the start of motion; the paper's was 0.419 m).
#[derive(Clone, Debug, Default, Serialize)]
pub struct InternalSimFigures {
    pub validations: u64,
    pub validated: u64,
    pub rejected: u64,
    /// Refusals by outcome.
    pub rejected_by: BTreeMap<String, u64>,
    /// Refusals by the pessimistic rollout of plans the nominal one passed.
    pub rejected_when_pessimistic: u64,
    /// Mission time from a plan to its verdict, ms.
    pub validation_ms_median: Option<f64>,
    pub validation_ms_max: Option<u32>,
    /// Traverses compared with their prediction.
    pub comparisons: usize,
    pub prediction_rmse_m_median: Option<f64>,
    pub prediction_rmse_m_max: Option<f64>,
    pub physics_steps: u64,
    pub triangles_max: u64,
    /// On the worker core: the batches, and how much faster than real
    /// time the simulated rover drove (simulated time over the frames of
    /// the batches that drove it).
    pub worker_batches: u64,
    pub speed_x_real_time: Option<f64>,
}

pub fn internal_sim(
    e: &Exploration,
    w: Option<&SimulatorWorker>,
    minor_frame_us: u32,
) -> Option<InternalSimFigures> {
    if !e.validates() {
        return None;
    }
    let c = &e.counters;
    let names = [
        "timeout",
        "tipped_over",
        "stuck",
        "missed",
        "no_ground",
        "no_way_back",
        "overhang",
        "fell",
        "too_steep_for_grip",
    ];
    Some(InternalSimFigures {
        validations: c.validations,
        validated: c.validated,
        rejected: c.rejected_by_sim,
        rejected_by: names
            .iter()
            .zip(c.sim_outcomes)
            .map(|(n, k)| (n.to_string(), k))
            .collect(),
        rejected_when_pessimistic: c.refused_when_pessimistic,
        validation_ms_median: crate::planner_figures::median(&e.validation_ms),
        validation_ms_max: e.validation_ms.iter().max().copied(),
        comparisons: e.prediction_rmse_m.len(),
        prediction_rmse_m_median: crate::planner_figures::median(&e.prediction_rmse_m),
        prediction_rmse_m_max: e.prediction_rmse_m.iter().copied().reduce(f64::max),
        worker_batches: w.map_or(0, |w| w.counters.batches),
        speed_x_real_time: w.and_then(|w| w.speed_x_real_time(minor_frame_us)),
        physics_steps: c.sim_physics_steps,
        triangles_max: c.sim_triangles_max,
    })
}
