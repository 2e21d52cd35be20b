//! Queries: start, goals, window, search, the plan published.

use super::*;
use crate::pick::{goal_distance2, point_ahead};

#[test]
fn a_query_plans_around_the_boulder_to_the_route_ahead_the_same_every_time() {
    let route = [[1.0, 2.0], [11.0, 2.0]];
    let mut rig = rig_on_a_floor();
    let mut t = task(&route);
    let frames = run_query(&mut t, &mut rig);
    let c = t.counters;
    assert_eq!((c.queries, c.solved, c.optimal), (1, 1, 1), "{c:?}");
    let plan = rig.published();
    assert!(plan.optimal && plan.eps == 1.0);
    let (first, last) = (plan.poses[0], plan.poses[plan.poses.len() - 1]);
    // From the rover to the route 8 m ahead (at any heading).
    assert!(
        (first[0] - 1.0).abs() < 0.2 && (first[1] - 2.0).abs() < 0.2,
        "{first:?}"
    );
    assert!(
        (last[0] - 9.0).abs() < 0.2 && (last[1] - 2.0).abs() < 0.2,
        "{last:?}"
    );
    // Clear of the 0.6 m boulder by at least the body's half width.
    for p in &plan.poses {
        let d = ((p[0] as f64 - 6.0).powi(2) + (p[1] as f64 - 2.0).powi(2)).sqrt();
        assert!(d > 0.6 + 0.3, "{p:?} is {d:.2} m from the boulder's centre");
    }
    // Every figure again, from a fresh task.
    let mut again_rig = rig_on_a_floor();
    let mut again = task(&route);
    assert_eq!(run_query(&mut again, &mut again_rig), frames);
    assert_eq!(again.counters, t.counters);
    assert_eq!(again_rig.plan.get().map(|p| p.value.clone()), Some(plan));
    assert_eq!(again.first_ms, t.first_ms);
}

#[test]
fn a_route_beyond_the_map_gives_no_goal_and_nothing_is_published() {
    let mut rig = rig_on_a_floor();
    let mut t = task(&[[1.0, 2.0], [-30.0, 2.0]]);
    run_query(&mut t, &mut rig);
    assert_eq!(
        (t.counters.queries, t.counters.no_goal),
        (1, 1),
        "{:?}",
        t.counters
    );
    assert!(rig.plan.get().is_none());
}

#[test]
fn exploring_plans_to_the_border_of_the_map_and_marks_the_plan_to_be_driven() {
    let mut rig = rig_on_a_floor();
    let mut t = exploring_task();
    run_query(&mut t, &mut rig);
    let plan = rig.published();
    assert!(plan.execute && plan.optimal, "{plan:?}");
    let last = plan.poses[plan.poses.len() - 1];
    // A border of the seen floor (nothing was seen beyond it) outside
    // the 3 m the rover has covered around (1, 2).
    let ex = t.exploration().unwrap_or_else(|| panic!("exploring"));
    assert_eq!(ex.counters.plans_executed, 1);
    assert_eq!(ex.executing, plan.query);
    let g = rig.exploration.goal.unwrap_or_else(|| panic!("no goal"));
    assert!(
        (last[0] as f64 - g[0]).abs() < 0.2 && (last[1] as f64 - g[1]).abs() < 0.2,
        "{last:?} {g:?}"
    );
    assert!(
        ((g[0] - 1.0).powi(2) + (g[1] - 2.0).powi(2)).sqrt() > 2.9,
        "{g:?}"
    );
    let border = g[0] < 0.2 || g[1] < 0.2 || g[0] > 11.8 || g[1] > 3.8;
    assert!(border, "{g:?}");
    // No new query while the plan is not driven.
    for f in 0..500 {
        rig.step(&mut t, 20_000 + f, 32);
    }
    assert_eq!(t.counters.queries, 1);
}

#[test]
fn a_query_that_drives_nothing_widens_the_next_window_up_to_its_most_a_plan_driven_restores_it() {
    // A 2 x 2 m floor all within the 3 m the rover covers where it
    // stands: nothing to explore from here.
    let mut pts = Vec::new();
    for i in 0..40 {
        for j in 0..40 {
            pts.push([i as f64 * 0.05, j as f64 * 0.05, 0.0]);
        }
    }
    let mut rig = rig_with_map(&pts, [1.0, 1.0, 0.17]);
    let mut t = exploring_task();
    let cfg = NavigatorParams::default();
    assert_eq!(t.window_half_m, cfg.window_m / 2.0);
    run_query(&mut t, &mut rig);
    assert_eq!(t.counters.queries, 1);
    assert_eq!(t.window_half_m, cfg.window_m * 1.5 / 2.0);
    // Never past the most.
    t.window_half_m = cfg.window_max_m / 2.0 - 1.0;
    t.end_query();
    assert_eq!(t.window_half_m, cfg.window_max_m / 2.0);
    assert!(rig.plan.get().is_none());
    // On a floor with somewhere to go, the plan driven brings the
    // window back.
    let mut rig = rig_on_a_floor();
    let mut t = exploring_task();
    t.window_half_m = cfg.window_max_m / 2.0;
    run_query(&mut t, &mut rig);
    assert!(rig.published().execute);
    assert_eq!(t.window_half_m, cfg.window_m / 2.0);
}

#[test]
fn a_goal_point_with_a_height_takes_ground_on_its_level_only() {
    // A point of the track home on the floor, under a deck 3 m up.
    let g = [2.0, 1.0];
    let floor = [2.3, 1.0, 0.0];
    let deck = [2.1, 1.0, 3.0];
    assert_eq!(goal_distance2(deck, g, Some(0.2)), None);
    let d = goal_distance2(floor, g, Some(0.2));
    assert!(d.is_some_and(|d| (d - 0.09).abs() < 1e-9), "{d:?}");
    // A route's point has no height: either level will do.
    assert!(goal_distance2(deck, g, None).is_some());
    // Out of reach in the plane.
    assert_eq!(goal_distance2([3.5, 1.0, 0.0], g, Some(0.2)), None);
}

#[test]
fn the_point_ahead_follows_the_route_and_stops_at_its_end() {
    let route = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]];
    let (p, yaw) = point_ahead(&route, false, 0, [2.0, 0.5], 5.0);
    assert!((p[0] - 7.0).abs() < 1e-9 && p[1].abs() < 1e-9, "{p:?}");
    assert!(yaw.abs() < 1e-9);
    let (p, yaw) = point_ahead(&route, false, 0, [8.0, 0.0], 5.0);
    assert!(
        (p[0] - 10.0).abs() < 1e-9 && (p[1] - 3.0).abs() < 1e-9,
        "{p:?}"
    );
    assert!((yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
    // Past the end of an open route: its end.
    let (p, _) = point_ahead(&route, false, 1, [10.0, 8.0], 5.0);
    assert!(
        (p[0] - 10.0).abs() < 1e-9 && (p[1] - 10.0).abs() < 1e-9,
        "{p:?}"
    );
    // A looped route wraps around to its start.
    let (p, _) = point_ahead(&route, true, 1, [10.0, 8.0], 5.0);
    let back = 3.0 / 200f64.sqrt();
    assert!(
        (p[0] - 10.0 * (1.0 - back)).abs() < 1e-9 && (p[1] - 10.0 * (1.0 - back)).abs() < 1e-9,
        "{p:?}"
    );
}
