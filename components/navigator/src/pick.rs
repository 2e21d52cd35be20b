//! The start and the goals of a query: the nearest drivable nodes to the
//! rover and to the goal points, and the goal points themselves (ahead
//! along a route, or back along the track home).

use speleo_exploration::{ExplorerPhase, ReturnReason};
use speleo_mapping::mls::{ground_near, MlsMap};
use speleo_traversability::Window;

use crate::query::Phase;
use crate::{Navigator, GOAL_REACH_M, LEVEL_M, PICK_PER_UNIT, START_CANDIDATES, START_REACH_M};

impl Navigator {
    /// Nearest drivable nodes to the rover and to the goal point.
    pub(crate) fn pick(&mut self, from: usize, units: usize) -> Phase {
        let trav = self.lat.trav();
        let nodes = trav.nodes();
        let to = from
            .saturating_add(units.saturating_mul(PICK_PER_UNIT))
            .min(nodes.len());
        let q = &mut self.query;
        for (i, n) in nodes.iter().enumerate().take(to).skip(from) {
            if !n.class.is_drivable() {
                continue;
            }
            let p = trav.position(n);
            let ds = (p[0] - q.rover[0]).powi(2) + (p[1] - q.rover[1]).powi(2);
            // Not the deck over the rover, nor the floor under its ramp.
            let level = (p[2] - q.rover[2]).abs() <= LEVEL_M;
            if ds <= START_REACH_M * START_REACH_M && level && q.start.is_none_or(|(_, d)| ds < d) {
                q.start = Some((i as u32, ds));
            }
            for k in 0..q.goal_count {
                let Some(dg) = goal_distance2(p, q.goals[k].0, q.goal_z[k]) else {
                    continue;
                };
                if q.goal[k].is_none_or(|(_, d)| dg < d) {
                    q.goal[k] = Some((i as u32, dg));
                }
            }
        }
        if to < nodes.len() {
            return Phase::Pick { next: to };
        }
        let angles = self.lat.angles();
        let Some((s, _)) = q.start else {
            self.counters.no_start += 1;
            if let Some(ex) = &mut self.explore {
                tracing::debug!(
                    x = q.rover[0],
                    y = q.rover[1],
                    nodes = nodes.len(),
                    "no drivable node under the rover"
                );
                ex.no_start();
            }
            self.end_query();
            return Phase::Idle;
        };
        let bin = |yaw: f64| speleo_planner::sbpl::angle_to_bin(yaw, angles);
        q.start_state = self.lat.state(s, bin(q.yaw));
        if let Some(ex) = &mut self.explore {
            // Exploring, and on the way home after nothing was left: a
            // frontier the rover could not reach from where it was may be
            // reachable from here (a side passage's far end, back at its
            // junction), so every stop home scans again.
            if matches!(
                ex.phase(),
                ExplorerPhase::Exploring | ExplorerPhase::Returning(ReturnReason::Explored)
            ) {
                let res = trav.resolution();
                let window = Window::around(q.rover[0], q.rover[1], self.window_half_m, res);
                ex.scan
                    .begin([q.rover[0], q.rover[1]], ex.target, Some(window));
                return Phase::Candidates;
            }
        }
        self.goal_order()
    }

    /// The goal points found, farthest first: on the route only the
    /// farthest is tried, on the way home each in turn.
    pub(crate) fn goal_order(&mut self) -> Phase {
        let trav = self.lat.trav();
        let q = &mut self.query;
        q.order_len = 0;
        for k in 0..q.goal_count {
            let Some((g, _)) = q.goal[k] else { continue };
            if q.order[..q.order_len].iter().any(|o| o.0 == g) {
                continue;
            }
            let at = trav.node(g).map_or([0.0; 3], |n| trav.position(n));
            q.order[q.order_len] = (g, at);
            q.order_len += 1;
            if self.explore.is_none() {
                break;
            }
        }
        if q.order_len == 0 {
            self.counters.no_goal += 1;
            if let Some(ex) = &mut self.explore {
                ex.home_failed();
            }
            self.end_query();
            return Phase::Idle;
        }
        self.try_goal(0)
    }
}

/// Horizontal ground patches near the rover, about `base_height_m` under
/// base_link, nearest first: where the graph may grow from.
pub(crate) fn start_candidates(
    mls: &MlsMap,
    base: [f64; 3],
    base_height_m: f64,
    tol_m: f64,
    out: &mut heapless::Vec<(i32, i32, f32), START_CANDIDATES>,
) {
    out.clear();
    let res = mls.params().resolution_m;
    let (cx, cy) = mls.cell_of(base[0], base[1]);
    let reach = (START_REACH_M / res).ceil() as i32;
    let ground = (base[2] - base_height_m) as f32;
    let tol = (2.0 * tol_m + 0.1) as f32;
    // (distance², cell, height), nearest first, ties by cell.
    let mut best: heapless::Vec<(i64, i32, i32, f32), START_CANDIDATES> = heapless::Vec::new();
    for dy in -reach..=reach {
        for dx in -reach..=reach {
            let d2 = (dx * dx + dy * dy) as i64;
            if d2 > (reach * reach) as i64 {
                continue;
            }
            let cell = mls.cell(cx + dx, cy + dy);
            let Some(g) = ground_near(cell, ground, tol) else {
                continue;
            };
            let e = (d2, cx + dx, cy + dy, g);
            let key = |v: &(i64, i32, i32, f32)| (v.0, v.1, v.2);
            let at = best
                .iter()
                .position(|b| key(&e) < key(b))
                .unwrap_or(best.len());
            if at < START_CANDIDATES {
                if best.is_full() {
                    best.pop();
                }
                let _ = best.insert(at, e);
            }
        }
    }
    for (_, ix, iy, z) in best {
        let _ = out.push((ix, iy, z));
    }
}

/// The squared distance in the plane from ground point `p` to goal point
/// `g`, when `p` may stand for it: within [`GOAL_REACH_M`], and on the
/// goal's level when the goal has a height (within [`LEVEL_M`]).
pub(crate) fn goal_distance2(p: [f64; 3], g: [f64; 2], z: Option<f64>) -> Option<f64> {
    let d2 = (p[0] - g[0]).powi(2) + (p[1] - g[1]).powi(2);
    let level = z.is_none_or(|z| (p[2] - z).abs() <= LEVEL_M);
    (d2 <= GOAL_REACH_M * GOAL_REACH_M && level).then_some(d2)
}

/// The point `ahead` metres along the route from the rover's projection
/// on segment `segment`, and the route's heading there.
pub(crate) fn point_ahead(
    route: &[[f64; 2]],
    looped: bool,
    segment: usize,
    at: [f64; 2],
    ahead: f64,
) -> ([f64; 2], f64) {
    let n = route.len();
    let segments = if looped { n } else { n.saturating_sub(1) };
    let seg = |i: usize| (route[i % n], route[(i + 1) % n]);
    let mut i = segment.min(segments.saturating_sub(1));
    let (a, b) = seg(i);
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len = dx.hypot(dy);
    // From the projection on the current segment.
    let t = if len > 0.0 {
        (((at[0] - a[0]) * dx + (at[1] - a[1]) * dy) / (len * len)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut left = ahead + t * len;
    loop {
        let (a, b) = seg(i);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = dx.hypot(dy);
        let last = !looped && i + 1 >= segments;
        if left <= len || last || i >= segment + segments {
            let f = if len > 0.0 {
                (left / len).min(1.0)
            } else {
                0.0
            };
            return ([a[0] + f * dx, a[1] + f * dy], dy.atan2(dx));
        }
        left -= len;
        i += 1;
    }
}
