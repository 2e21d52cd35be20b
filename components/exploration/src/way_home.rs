//! Goal points on the way home, ranked by the way home through each: the
//! straight line from the rover to the point, then the track from the
//! point home. Points back along the track are always offered; earlier
//! track points on the rover's level within reach across are offered as
//! shortcuts, so a loop driven on the way out is cut where its end passes
//! near its start instead of being driven round again. The planner and
//! the internal simulation judge every goal before it is driven.

use crate::trail::{Trail, LEVEL_M};

/// Goal points offered at most (the navigator's goal list holds 32).
pub const HOME_GOALS: usize = 32;

/// Goal points nearer each other than this are one goal, m: the planner
/// takes the drivable node nearest a point within 1 m.
const SAME_GOAL_M: f64 = 0.5;

#[derive(Clone, Copy, Debug, PartialEq)]
struct HomeGoal {
    point: [f64; 3],
    /// The straight line to the point and the track home from it, m.
    way_m: f64,
    /// The track home from the point, m.
    track_m: f64,
}

/// Goal points home from `at`, best first, into `out`. `from` is the
/// earliest track point near the rover; points back along the track
/// from it are taken every metre from `ahead_m` down to `nearest_m`, and
/// earlier track points within `ahead_m` across and on the rover's level
/// (home itself at any distance under that) as shortcuts.
pub fn home_goals(
    trail: &Trail,
    from: usize,
    at: [f64; 3],
    ahead_m: f64,
    nearest_m: f64,
    out: &mut impl FnMut([f64; 3]),
) {
    let mut best: heapless::Vec<HomeGoal, HOME_GOALS> = heapless::Vec::new();
    let from_track_m = trail.length_back_from(from);
    let mut ahead = ahead_m;
    while ahead >= nearest_m {
        if let Some(point) = trail.back_from(from, ahead) {
            let track_m = (from_track_m - ahead).max(0.0);
            offer(&mut best, goal(at, point, track_m));
        }
        ahead -= 1.0;
    }
    let earlier = &trail.points()[..from.min(trail.points().len())];
    for (i, &point) in earlier.iter().enumerate() {
        let d = across(at, point);
        let on_level = (point[2] - at[2]).abs() <= LEVEL_M;
        if d > ahead_m || (d < nearest_m && i > 0) || !on_level {
            continue;
        }
        offer(&mut best, goal(at, point, trail.length_back_from(i)));
    }
    for g in &best {
        out(g.point);
    }
}

fn goal(at: [f64; 3], point: [f64; 3], track_m: f64) -> HomeGoal {
    HomeGoal {
        point,
        way_m: across(at, point) + track_m,
        track_m,
    }
}

/// `a` comes before `b`: a shorter way home, then less track left.
fn before(a: &HomeGoal, b: &HomeGoal) -> bool {
    a.way_m
        .total_cmp(&b.way_m)
        .then(a.track_m.total_cmp(&b.track_m))
        .is_lt()
}

/// Keep `g` in the ranked list unless a goal as good stands within
/// [`SAME_GOAL_M`] of it; a worse one there gives way to it.
fn offer(best: &mut heapless::Vec<HomeGoal, HOME_GOALS>, g: HomeGoal) {
    if let Some(k) = best
        .iter()
        .position(|b| across(b.point, g.point) < SAME_GOAL_M)
    {
        if !before(&g, &best[k]) {
            return;
        }
        best.remove(k);
    }
    let at = best
        .iter()
        .position(|b| before(&g, b))
        .unwrap_or(best.len());
    if at == HOME_GOALS {
        return;
    }
    if best.is_full() {
        best.pop();
    }
    let _ = best.insert(at, g);
}

fn across(a: [f64; 3], b: [f64; 3]) -> f64 {
    (b[0] - a[0]).hypot(b[1] - a[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn goals(trail: &Trail, at: [f64; 3]) -> Vec<[f64; 3]> {
        let from = trail.earliest_near(at, 2.0).expect("near the track");
        let mut v = Vec::new();
        home_goals(trail, from, at, 8.0, 2.0, &mut |g| v.push(g));
        v
    }

    #[test]
    fn a_loop_that_ends_near_home_is_cut_across_not_driven_round_again() {
        // Out 6 m east, 7 m north and 6 m back west: the track ends 7 m
        // north of home, 19 m from it along the track.
        let mut t = Trail::new(1000, 1.0);
        for k in 0..=6 {
            t.record([k as f64, 0.0, 0.0]);
        }
        for k in 1..=7 {
            t.record([6.0, k as f64, 0.0]);
        }
        for k in 1..=6 {
            t.record([6.0 - k as f64, 7.0, 0.0]);
        }
        let at = [0.0, 7.0, 0.0];
        let g = goals(&t, at);
        assert_eq!(g[0], [0.0, 0.0, 0.0], "home first: {g:?}");
        // The track back round the loop is still offered, after home.
        let from = t.earliest_near(at, 2.0).expect("near");
        let round = t.back_from(from, 8.0).expect("goal");
        let k = g.iter().position(|p| *p == round).expect("offered");
        assert!(k > 0, "{g:?}");
    }

    #[test]
    fn along_a_straight_track_the_farthest_point_back_comes_first() {
        let mut t = Trail::new(1000, 1.0);
        for k in 0..=20 {
            t.record([k as f64, 0.0, 0.0]);
        }
        let g = goals(&t, [20.0, 0.0, 0.0]);
        // The earliest point near is x = 18, the first goal 8 m back.
        assert_eq!(g[0], [10.0, 0.0, 0.0], "{g:?}");
        assert!(g.iter().all(|p| p[0] < 18.5), "nothing ahead: {g:?}");
        // One goal a point: none nearer another than half a metre.
        for (i, a) in g.iter().enumerate() {
            for b in &g[i + 1..] {
                assert!(across(*a, *b) >= SAME_GOAL_M, "{a:?} {b:?}");
            }
        }
    }

    #[test]
    fn the_track_on_another_level_is_no_shortcut() {
        // Along the floor, up a ramp to a deck 3 m up, and back west along
        // the deck 4 m north of the floor's track.
        let mut t = Trail::new(1000, 1.0);
        for k in 0..=10 {
            t.record([k as f64, 0.0, 0.0]);
        }
        for k in 1..=4 {
            t.record([10.0, k as f64, 0.75 * k as f64]);
        }
        for k in 1..=10 {
            t.record([10.0 - k as f64, 4.0, 3.0]);
        }
        let g = goals(&t, [0.0, 4.0, 3.0]);
        assert!(!g.is_empty());
        assert!(g.iter().all(|p| p[2] >= 2.0), "on the floor below: {g:?}");
    }
}
