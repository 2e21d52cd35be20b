//! The internal simulation's verdicts on plans: refused goals, partial
//! plans, the worker core, goals over rocks.

use super::*;
use crate::query::Phase;
use crate::{ExplorationCounters, InStep};
use speleo_messages::PlanMsg;

fn ledge_mission(worker_units: u32) -> (ExplorationCounters, PlanMsg, (u64, u64)) {
    ledge_mission_from(worker_units, rig_before_a_ledge(8.0, false))
}

fn ledge_mission_from(
    worker_units: u32,
    mut rig: Rig,
) -> (ExplorationCounters, PlanMsg, (u64, u64)) {
    // A planner told the rover steps up to 0.35 m, drawn toward the
    // far side of the ledge, and not wary of bumps (the ledge's edge).
    let mut cfg = NavigatorParams::default();
    cfg.trav.max_step_m = 0.35;
    cfg.trav.ground_clearance_m = 0.4;
    cfg.surface.bump_weight = 0.0;
    let prims = speleo_planner::primitives::generate(&Default::default());
    let e = Settings {
        weight_target: 1.0,
        ..Default::default()
    };
    // The nominal rollout alone: with the pessimistic one's grip, the
    // tight turn at the ledge's foot that the lower goal's plan makes
    // slides into the ledge and is refused too.
    let sim = speleo_simulator::InternalSim::new(speleo_simulator::SimulatorParams {
        pessimistic_friction: 0.0,
        ..Default::default()
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let ex = Exploration::new(
        e.explorer_params(),
        e.candidate_params(),
        Some([40.0, 2.0]),
        0.0,
    )
    .with_simulator(sim);
    let mut sync = None;
    let mut host: Box<dyn Rehearsal> = Box::new(InStep);
    if worker_units > 0 {
        let w = Worker::spawn(worker_units);
        sync = Some(w.cp.sync());
        host = Box::new(w);
    }
    let mut t = Navigator::new(&cfg, &prims, 0.1, &[], false, 0.17)
        .unwrap_or_else(|e| panic!("{e}"))
        .with_exploration(ex);
    let (mut frame, mut validating) = (0, 0);
    for f in 0..400_000 {
        if let Some(s) = &sync {
            s.wait_idle();
        }
        validating += matches!(t.phase, Phase::Validate) as u64;
        rig.step_hosted(&mut t, f, 32, host.as_mut());
        frame = f;
        if rig.plan.get().is_some_and(|p| p.value.execute) {
            break;
        }
    }
    let ex = t.exploration().unwrap_or_else(|| panic!("exploring"));
    (ex.counters, rig.published(), (frame, validating))
}

#[test]
fn a_goal_beyond_a_ledge_the_rover_cannot_climb_is_refused_by_the_simulation_and_another_chosen() {
    let (c, plan, _) = ledge_mission(0);
    // The first goal lay up the ledge; the simulated rover failed there.
    assert!(c.rejected_by_sim >= 1, "{c:?}");
    assert_eq!(c.validated, 1, "{c:?}");
    assert_eq!(c.validations, c.rejected_by_sim + 1, "{c:?}");
    assert!(plan.execute, "{plan:?}");
    // The plan driven stays on the lower floor.
    for p in &plan.poses {
        assert!(p[0] < 9.6, "{p:?} climbs the ledge");
    }
}

#[test]
fn when_every_goal_lies_past_a_ledge_the_part_of_the_way_the_simulation_drove_is_driven() {
    // The near end shut: the only frontier is past the ledge, 7 m on.
    let (c, plan, _) = ledge_mission_from(0, rig_before_a_ledge(3.0, true));
    assert_eq!(c.validated, 0, "{c:?}");
    assert!(c.rejected_by_sim >= 1, "{c:?}");
    assert_eq!(c.partial_plans, 1, "{c:?}");
    assert!(plan.execute, "{plan:?}");
    // Toward the ledge, and stopping at least a metre short of its
    // foot, where the simulated rover stalled.
    let end = plan.poses.last().unwrap_or_else(|| panic!("no poses"));
    assert!(end[0] > 5.0 && end[0] < 9.0, "{end:?}");
    for p in &plan.poses {
        assert!(p[0] < 9.0, "{p:?} too near the ledge");
    }
}

#[test]
fn on_a_worker_core_the_simulation_gives_the_same_verdicts_sooner_and_the_same_every_time() {
    let (c0, plan0, (frame0, validating0)) = ledge_mission(0);
    let (c1, plan1, (frame1, validating1)) = ledge_mission(120);
    assert_eq!(c1.validations, c0.validations, "{c1:?}");
    assert_eq!(c1.rejected_by_sim, c0.rejected_by_sim, "{c1:?}");
    assert_eq!(c1.sim_outcomes, c0.sim_outcomes, "{c1:?}");
    assert_eq!(c1.sim_physics_steps, c0.sim_physics_steps, "{c1:?}");
    assert_eq!(plan1.poses, plan0.poses);
    // The validations are eight times quicker (486 frames against
    // 3,879); planning frames included, the plan comes more than twice
    // as soon.
    assert!(
        validating1 * 6 < validating0,
        "{validating1} frames validating vs {validating0} in the window"
    );
    assert!(
        frame1 * 2 < frame0,
        "{frame1} frames vs {frame0} in the window"
    );
    let again = ledge_mission(120);
    assert_eq!(again.2 .0, frame1, "the verdicts come at the same frames");
    assert_eq!(again.1.poses, plan1.poses);
}

/// Exploring a flat corridor toward its far end from x = 3 m, with a
/// dome `rock` m tall (0.4 m across) at `at` on the floor: the
/// counters and the first plan marked to be driven.
/// The first plan driven in a corridor with a dome `rock` tall at
/// `at`, with the exploration's goal rule at 6 cm, or with the
/// planner's rock limit at 6 cm (`planner_limit`) instead.
fn first_plan_with_a_rock(
    rock: f64,
    at: [f64; 2],
    planner_limit: bool,
) -> (ExplorationCounters, PlanMsg) {
    let ground = |x: f64, y: f64| {
        let r2 = (x - at[0]).powi(2) + (y - at[1]).powi(2);
        rock * (1.0 - r2 / 0.04).max(0.0)
    };
    let sensors = [[2.0, 2.0, 0.8], [5.0, 2.0, 0.8], [8.0, 2.0, 0.8]];
    let mut rig = rig_in_a_corridor(ground, true, [3.0, 2.0, 0.17], &sensors);
    let (goal_rule, limit) = if planner_limit {
        (0.0, 0.06)
    } else {
        (0.06, 0.0)
    };
    let mut cfg = NavigatorParams::default();
    cfg.surface.max_bump_m = limit;
    let prims = speleo_planner::primitives::generate(&Default::default());
    let e = Settings {
        weight_target: 1.0,
        max_goal_rock_m: goal_rule,
    };
    let ex = Exploration::new(
        e.explorer_params(),
        e.candidate_params(),
        Some([40.0, 2.0]),
        0.0,
    );
    let mut t = Navigator::new(&cfg, &prims, 0.1, &[], false, 0.17)
        .unwrap_or_else(|e| panic!("{e}"))
        .with_exploration(ex);
    for f in 0..100_000 {
        rig.step(&mut t, f, 32);
        if rig.plan.get().is_some_and(|p| p.value.execute) {
            break;
        }
    }
    let ex = t.exploration().unwrap_or_else(|| panic!("exploring"));
    (ex.counters, rig.published())
}

#[test]
fn a_goal_over_a_rock_is_not_driven_to_and_another_is_chosen() {
    for planner_limit in [false, true] {
        a_goal_over_a_rock_is_refused(planner_limit);
    }
}

fn a_goal_over_a_rock_is_refused(planner_limit: bool) {
    let (c, plan) = first_plan_with_a_rock(0.0, [0.0, 0.0], planner_limit);
    assert_eq!(c.goals_on_rocks, 0, "{c:?}");
    let end = *plan.poses.last().unwrap_or_else(|| panic!("no poses"));
    let rock_at = [end[0] as f64, end[1] as f64];
    // A 4 cm one there is the map's roughness: driven to.
    let (c, low) = first_plan_with_a_rock(0.04, rock_at, planner_limit);
    assert_eq!(c.goals_on_rocks, 0, "{c:?}");
    let low_end = low.poses.last().unwrap_or_else(|| panic!("no poses"));
    assert_eq!(low_end[..2], end[..2]);
    // The same corridor with an 8 cm rock where that plan ended: under
    // the body's 12 cm clearance, so the map lets the rover over it.
    let (c, plan) = first_plan_with_a_rock(0.08, rock_at, planner_limit);
    assert_eq!(c.goals_on_rocks, 1, "{c:?}");
    assert!(plan.execute, "{plan:?}");
    let other = *plan.poses.last().unwrap_or_else(|| panic!("no poses"));
    assert!(
        (other[0] - end[0]).hypot(other[1] - end[1]) > 1.0,
        "{other:?} by the rock at {end:?}"
    );
    if planner_limit {
        // Nor does the body pass over it on the way.
        let clear = nearest_m(&plan, rock_at);
        assert!(clear > 0.35, "{clear} m from the rock");
    }
}
