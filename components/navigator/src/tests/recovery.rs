//! Recovery: retraces, back-outs, barred places, stranding.

use super::*;
use crate::exploration::{NO_GO_RADIUS_M, RIM_RADIUS_M};
use crate::ExplorationCounters;
use speleo_exploration::ExplorerPhase;
use speleo_messages::PlanMsg;

/// A rover standing at x = 8 m before the ledge, its track coming
/// from `from_x`, stranded (no plan): the planner's steps until a
/// retrace is marked to be driven or `frames` pass; the counters and
/// the plans shown, in order.
fn retrace_before_a_ledge(from_x: f64, frames: u64) -> (ExplorationCounters, Vec<PlanMsg>) {
    let (c, shown, _) = retraces_before_a_ledge(from_x, frames);
    (c, shown)
}

/// [`retrace_before_a_ledge`], and the explorer's phase at the end.
fn retraces_before_a_ledge(
    from_x: f64,
    frames: u64,
) -> (ExplorationCounters, Vec<PlanMsg>, ExplorerPhase) {
    let mut rig = rig_before_a_ledge(8.0, false);
    let cfg = NavigatorParams::default();
    let prims = speleo_planner::primitives::generate(&Default::default());
    let mut ex = validating_exploration();
    let ground = |x: f64| if x < 10.0 { 0.17 } else { 0.17 + LEDGE_M };
    let steps = ((from_x - 8.0).abs() / 0.1) as u64;
    for k in 0..=steps {
        let x = from_x + (8.0 - from_x) * k as f64 / steps as f64;
        rig.slam.publish(
            k * 100_000_000,
            SlamPose {
                position: [x, 2.0, ground(x)],
                orientation: [1.0, 0.0, 0.0, 0.0],
                keyframes: 1,
            },
        );
        rig.observe(&mut ex, k * 100_000_000);
    }
    ex.no_start();
    let mut t = Navigator::new(&cfg, &prims, 0.1, &[], false, 0.17)
        .unwrap_or_else(|e| panic!("{e}"))
        .with_exploration(ex);
    let mut shown: Vec<PlanMsg> = Vec::new();
    for f in 0..frames {
        rig.step(&mut t, steps + 1 + f, 32);
        if let Some(p) = rig.plan.get() {
            if shown.last() != Some(&p.value) {
                shown.push(p.value.clone());
            }
            if p.value.execute {
                break;
            }
        }
        if t.exploration()
            .is_some_and(|e| e.phase() == ExplorerPhase::Stranded)
        {
            break;
        }
    }
    let ex = t.exploration().unwrap_or_else(|| panic!("exploring"));
    (ex.counters, shown, ex.phase())
}

#[test]
fn retraces_refused_again_and_again_at_one_place_end_in_going_home_not_a_loop() {
    // Only back up the ledge leads anywhere: four refusals, then home
    // by plans (none, the ledge is the only way), four more, stranded.
    let (c, shown, phase) = retraces_before_a_ledge(13.0, 200_000);
    assert!(shown.iter().all(|p| !p.execute), "{shown:?}");
    assert_eq!(phase, ExplorerPhase::Stranded, "{c:?}");
    assert_eq!(c.retraces_refused, 8, "{c:?}");
}

#[test]
fn a_back_out_over_a_drop_is_refused_by_the_simulation_and_the_other_way_driven() {
    use speleo_control::StopReason;
    use speleo_messages::WheelCommand;
    // On a shelf whose edge is 0.4 m behind the rover, a 0.8 m drop
    // under it; the rover faces away from it and is stuck.
    let ground = |x: f64, _| if x < 9.3 { -0.8 } else { 0.0 };
    let sensors = [[6.0, 2.0, 0.0], [10.0, 2.0, 0.8], [13.0, 2.0, 0.8]];
    let mut rig = rig_in_a_corridor(ground, false, [9.7, 2.0, 0.17], &sensors);
    let cfg = NavigatorParams::default();
    let prims = speleo_planner::primitives::generate(&Default::default());
    let mut ex = validating_exploration();
    rig.observe(&mut ex, 0);
    rig.command.publish(
        100_000_000,
        WheelCommand {
            done: true,
            stop: Some(StopReason::Stuck),
            ..Default::default()
        },
    );
    let mut t = Navigator::new(&cfg, &prims, 0.1, &[], false, 0.17)
        .unwrap_or_else(|e| panic!("{e}"))
        .with_exploration(ex);
    let mut shown: Vec<PlanMsg> = Vec::new();
    for f in 0..200_000 {
        rig.step(&mut t, 2 + f, 32);
        if let Some(p) = rig.plan.get() {
            if shown.last() != Some(&p.value) {
                shown.push(p.value.clone());
            }
            if p.value.execute {
                break;
            }
        }
    }
    let c = t.exploration().map(|e| e.counters).unwrap_or_default();
    let ends: Vec<f32> = shown
        .iter()
        .filter_map(|p| p.poses.last())
        .map(|q| q[0])
        .collect();
    // Backward over the edge: shown, simulated, refused. Forward:
    // driven. Both straight, facing ahead.
    assert_eq!(
        (c.backed_out, c.back_outs_refused),
        (2, 1),
        "{c:?} {ends:?}"
    );
    let driven = shown.last().unwrap_or_else(|| panic!("nothing shown"));
    assert!(driven.execute, "{shown:?}");
    assert!(
        shown[..shown.len() - 1].iter().all(|p| !p.execute),
        "{shown:?}"
    );
    assert!((ends[0] - 8.7).abs() < 1e-3, "{ends:?}");
    assert!((ends[ends.len() - 1] - 10.7).abs() < 1e-3, "{ends:?}");
    assert!(driven.poses.iter().all(|q| q[3].abs() < 1e-6), "{driven:?}");
}

#[test]
fn a_retrace_is_driven_only_once_the_simulation_passes_it() {
    // Back along the flat floor: shown, simulated, then driven.
    let (c, shown) = retrace_before_a_ledge(3.0, 20_000);
    assert_eq!((c.retraces, c.validations, c.validated), (1, 1, 1), "{c:?}");
    assert_eq!(shown.len(), 2, "{shown:?}");
    assert!(!shown[0].execute);
    assert!(shown[1].execute);
    assert_eq!(shown[0].poses, shown[1].poses);
    assert!(shown[1].poses.len() > 2, "{:?}", shown[1]);
    assert!(shown[1].poses.iter().all(|q| q[0] < 8.1), "{:?}", shown[1]);
    // On the floor, not at base_link's height along the track: the
    // simulation's strip follows the poses.
    assert!(
        shown[1].poses.iter().all(|q| q[2].abs() < 0.05),
        "{:?}",
        shown[1]
    );
    // Back up the ledge the track came down: refused, never driven,
    // and tried again (the other way) at the next query.
    let (c, shown) = retrace_before_a_ledge(13.0, 20_000);
    assert!(c.retraces_refused >= 1, "{c:?} {shown:?}");
    assert!(shown.iter().all(|p| !p.execute), "{shown:?}");
    assert!(c.retraces >= 2, "{c:?}");
}

/// The far end of the floor as the target, and perhaps a place the
/// rover was stuck at on the straight way there: the plan.
fn plan_toward_the_far_end(no_go: Option<[f64; 3]>) -> PlanMsg {
    plan_toward_the_far_end_barred(no_go, None)
}

/// As [`plan_toward_the_far_end`], with a rim kept too.
fn plan_toward_the_far_end_barred(no_go: Option<[f64; 3]>, rim: Option<[f64; 3]>) -> PlanMsg {
    let e = Settings {
        weight_target: 5.0,
        ..Default::default()
    };
    let mut ex = Exploration::new(
        e.explorer_params(),
        e.candidate_params(),
        Some([12.0, 2.0]),
        0.0,
    );
    if let Some(p) = no_go {
        let _ = ex.no_go.push_back(p);
    }
    if let Some(p) = rim {
        let _ = ex.rims.push_back(p);
    }
    let mut t = task(&[]).with_exploration(ex);
    let mut rig = rig_on_a_floor();
    run_query(&mut t, &mut rig);
    rig.published()
}

/// The plan made with nothing barred, and its first pose past x = 3
/// (x, y and ground height).
fn free_plan_and_its_pose_past_x3() -> (PlanMsg, [f64; 3]) {
    let free = plan_toward_the_far_end(None);
    let p = free
        .poses
        .iter()
        .find(|p| p[0] > 3.0)
        .copied()
        .unwrap_or_else(|| panic!("{free:?}"));
    (free, [p[0] as f64, p[1] as f64, p[2] as f64])
}

#[test]
fn a_rim_the_rover_was_stopped_at_is_kept_out_of_its_plans() {
    let (free, [x, y, z]) = free_plan_and_its_pose_past_x3();
    let at = [x, y];
    assert!(nearest_m(&free, at) < RIM_RADIUS_M);
    let wary = plan_toward_the_far_end_barred(None, Some([x, y, z]));
    assert!(wary.execute, "{wary:?}");
    assert!(nearest_m(&wary, at) > RIM_RADIUS_M, "{wary:?}");
}

#[test]
fn a_place_the_rover_was_stuck_at_is_kept_out_of_its_plans() {
    // A pose of the plan made without it, before the boulder.
    let (_, [x, y, _]) = free_plan_and_its_pose_past_x3();
    let at = [x, y];
    let wary = plan_toward_the_far_end(Some([at[0], at[1], 0.0]));
    assert!(wary.execute, "{wary:?}");
    assert!(nearest_m(&wary, at) > NO_GO_RADIUS_M, "{wary:?}");
}

/// Exploring, the rover driven from x = 1 to x = 5 along y = 2,
/// facing +x.
fn driven_from_x1_to_x5() -> (Exploration, Rig) {
    let e = Settings::default();
    let mut ex = Exploration::new(e.explorer_params(), e.candidate_params(), None, 0.0);
    let mut rig = rig_on_a_floor();
    for k in 0..=40 {
        let x = 1.0 + 0.1 * k as f64;
        rig.slam.publish(
            k * 100_000_000,
            SlamPose {
                position: [x, 2.0, 0.17],
                orientation: [1.0, 0.0, 0.0, 0.0],
                keyframes: 1,
            },
        );
        rig.observe(&mut ex, k * 100_000_000);
    }
    (ex, rig)
}

#[test]
fn a_stuck_rover_backs_out_a_metre_straight_then_plans_then_backs_out_forward_and_remembers_the_place(
) {
    use speleo_control::StopReason;
    use speleo_messages::WheelCommand;
    let (mut ex, mut rig) = driven_from_x1_to_x5();
    // Then stuck.
    rig.command.publish(
        4_100_000_000,
        WheelCommand {
            done: true,
            stop: Some(StopReason::Stuck),
            ..Default::default()
        },
    );
    assert!(rig.ready(&mut ex, 4_100_000_000));
    assert_eq!(ex.no_go.len(), 1);
    let stuck_at = ex.no_go.front().copied().unwrap_or_default();
    assert!((stuck_at[0] - 5.0).abs() < 1e-9, "{stuck_at:?}");
    assert!(ex.retrace_due());
    rig.retrace(&mut ex, 4_200_000_000, 9, 8.0);
    let plan = rig.published();
    assert!(plan.execute && plan.query == 9, "{plan:?}");
    let last = plan.poses[plan.poses.len() - 1];
    // A metre straight back (not the 8 m of a retrace), facing ahead
    // still: driven in reverse, without turning.
    assert!(
        (last[0] - 4.0).abs() < 1e-3 && (last[1] - 2.0).abs() < 1e-3,
        "{plan:?}"
    );
    assert!(plan.poses.iter().all(|p| p[3].abs() < 1e-6), "{plan:?}");
    assert_eq!(ex.counters.backed_out, 1);
    // Stuck again on the way back: forward this time, and the place is
    // known already.
    rig.command.publish(
        4_300_000_000,
        WheelCommand {
            done: true,
            plan: 9,
            stop: Some(StopReason::Stuck),
            ..Default::default()
        },
    );
    assert!(rig.ready(&mut ex, 4_300_000_000));
    assert_eq!(ex.no_go.len(), 1);
    // The planner is asked first; only when it finds nothing from here
    // does the rover back out again.
    assert!(!ex.retrace_due());
    ex.query_over();
    assert!(ex.retrace_due());
    // Waiting for the next query does not act on the back-out's end
    // again (that undid the query's verdict for 4,000 queries).
    assert!(rig.ready(&mut ex, 4_350_000_000));
    assert!(ex.retrace_due());
    rig.retrace(&mut ex, 4_400_000_000, 10, 8.0);
    let last = *rig
        .published()
        .poses
        .last()
        .unwrap_or_else(|| panic!("no poses"));
    assert!((last[0] - 6.0).abs() < 1e-3, "{last:?}");
}

#[test]
fn a_rover_stuck_after_a_back_out_each_way_retraces_its_track_steered_then_backs_out_again() {
    use speleo_control::StopReason;
    use speleo_messages::WheelCommand;
    let (mut ex, mut rig) = driven_from_x1_to_x5();
    let straight = |p: &PlanMsg| p.poses.iter().all(|q| q[3].abs() < 1e-6);
    let mut t = 4_100_000_000;
    let mut escapes = Vec::new();
    for query in 9..15 {
        // Stuck where it stands, and the planner finds nothing.
        rig.command.publish(
            t,
            WheelCommand {
                done: true,
                plan: query - 1,
                stop: Some(StopReason::Stuck),
                ..Default::default()
            },
        );
        assert!(rig.ready(&mut ex, t));
        ex.query_over();
        assert!(ex.retrace_due());
        rig.retrace(&mut ex, t + 50_000_000, query, 3.0);
        let plan = rig.published();
        let last = plan.poses[plan.poses.len() - 1];
        escapes.push(if last[0] > 5.5 {
            "back-out forward"
        } else if (last[0] - 4.0).abs() < 1e-3 && straight(&plan) {
            "back-out backward"
        } else if plan
            .poses
            .iter()
            .all(|q| (q[3].abs() - core::f32::consts::PI).abs() < 1e-3)
        {
            "retrace forward"
        } else if straight(&plan) && last[0] < 3.0 {
            "retrace backward"
        } else {
            panic!("{plan:?}")
        });
        t += 100_000_000;
    }
    assert_eq!(
        escapes,
        [
            "back-out backward",
            "back-out forward",
            "retrace forward",
            "retrace backward",
            "back-out backward",
            "back-out forward"
        ]
    );
    assert_eq!((ex.counters.backed_out, ex.counters.retraces), (4, 2));
}

#[test]
fn a_retrace_drives_the_track_forward_and_backward_when_that_got_nowhere() {
    let (mut ex, mut rig) = driven_from_x1_to_x5();
    ex.no_start();
    assert!(ex.retrace_due());
    rig.retrace(&mut ex, 4_200_000_000, 9, 3.0);
    let plan = rig.published();
    let last = plan.poses[plan.poses.len() - 1];
    assert!((last[0] - 2.0).abs() < 0.6, "{plan:?}");
    // Facing back along the track (-x) all the way: driven forward.
    let back = |p: &[f32; 4]| (p[3].abs() - core::f32::consts::PI).abs() < 1e-3;
    assert!(plan.poses.iter().all(back), "{plan:?}");
    // It got nowhere (stopped where it began): backward this time,
    // facing +x as the rover does...
    ex.no_start();
    rig.retrace(&mut ex, 4_300_000_000, 10, 3.0);
    let plan = rig.published();
    assert!(plan.poses.iter().all(|p| p[3].abs() < 1e-3), "{plan:?}");
    // ...and forward again after that.
    ex.no_start();
    rig.retrace(&mut ex, 4_400_000_000, 11, 3.0);
    assert!(rig.published().poses.iter().all(back));
    assert_eq!(ex.counters.retraces, 3);
}

#[test]
fn when_nothing_is_left_but_barred_places_they_are_forgotten_once_a_mission() {
    let e = Settings::default();
    let mut ex = Exploration::new(e.explorer_params(), e.candidate_params(), None, 0.0);
    assert!(!ex.second_look(), "nothing was barred");
    let _ = ex.no_go.push_back([1.0, 2.0, 0.0]);
    ex.explorer.reject([3.0, 4.0]);
    assert!(ex.second_look());
    assert!(ex.no_go.is_empty() && ex.explorer.rejected().is_empty());
    assert_eq!(ex.phase(), ExplorerPhase::Exploring);
    assert_eq!(ex.counters.second_looks, 1);
    let _ = ex.no_go.push_back([1.0, 2.0, 0.0]);
    assert!(!ex.second_look(), "once a mission");
    assert_eq!(ex.no_go.len(), 1);
}

#[test]
fn a_rover_that_made_no_progress_drops_its_goal_without_backing_out() {
    use speleo_control::StopReason;
    use speleo_messages::WheelCommand;
    let e = Settings::default();
    let mut ex = Exploration::new(e.explorer_params(), e.candidate_params(), None, 0.0);
    let mut rig = rig_on_a_floor();
    rig.slam.publish(
        0,
        SlamPose {
            position: [5.0, 2.0, 0.17],
            orientation: [1.0, 0.0, 0.0, 0.0],
            keyframes: 1,
        },
    );
    rig.observe(&mut ex, 0);
    // Circling a goal it could not settle on: the rover moves freely,
    // so the place is no obstacle, but the goal is not tried again.
    rig.exploration.goal = Some([5.5, 2.0, 0.0]);
    rig.command.publish(
        100_000_000,
        WheelCommand {
            done: true,
            stop: Some(StopReason::NoProgress),
            ..Default::default()
        },
    );
    assert!(rig.ready(&mut ex, 100_000_000));
    assert!(ex.no_go.is_empty());
    assert!(!ex.retrace_due());
    assert_eq!(ex.explorer.rejected(), &[[5.5, 2.0]]);
}
