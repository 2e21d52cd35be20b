//! Goals on seen ground. A frontier patch lies next to ground no scan has
//! seen, and a rover sent to stand on it stands partly over that ground.
//! Mostly the ground is there (a ring gap, the next stretch of a tube),
//! but at an edge the LiDAR cannot see past, a roof's rim or a slab's
//! edge, it is air. The goal moves inward, away from the unseen cells, to
//! the first patch with none under the body: the rover sees as much from
//! there, less than a metre back.

use speleo_traversability::{TravClass, TravMap};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirmGoalParams {
    /// Unseen cells within this radius of a goal lie under the body, m.
    pub body_radius_m: f64,
    /// The goal moves inward at most this far, m.
    pub max_shift_m: f64,
    /// Cells within this height of the goal's ground count as its level,
    /// m; the ground of the patches walked inward may change by at most
    /// this per cell.
    pub level_m: f64,
}

impl Default for FirmGoalParams {
    fn default() -> Self {
        FirmGoalParams {
            body_radius_m: 0.45,
            max_shift_m: 1.0,
            level_m: 0.3,
        }
    }
}

/// The goal for candidate `node`: the node itself when no cell within the
/// body's radius is unseen; otherwise, walking away from the unseen cells
/// a cell at a time up to `max_shift_m`, the first drivable patch with
/// none (or, failing that, the one with fewest, the candidate's own on a
/// tie); the walk stops at an obstacle within `clearance_m` or where the
/// ground is not there. Returns the node and the number of cells looked
/// up (work).
pub fn firm_goal(trav: &TravMap, node: u32, clearance_m: f64, p: &FirmGoalParams) -> (u32, u64) {
    let mut work = 0u64;
    let Some(n) = trav.node(node) else {
        return (node, work);
    };
    let (unseen, pull) = unseen_under(trav, n.ix, n.iy, n.ground_z, p, &mut work);
    if unseen == 0 {
        return (node, work);
    }
    let len = pull[0].hypot(pull[1]);
    if len < 1e-9 {
        return (node, work);
    }
    let dir = [pull[0] / len, pull[1] / len];
    let mut best = (unseen, node);
    let (mut z, mut last) = (n.ground_z, (n.ix, n.iy));
    let steps = (p.max_shift_m / trav.resolution()).round() as i32;
    for k in 1..=steps {
        let cell = (
            n.ix + (k as f64 * dir[0]).round() as i32,
            n.iy + (k as f64 * dir[1]).round() as i32,
        );
        if cell == last {
            continue;
        }
        last = cell;
        work += 1;
        let on = trav
            .nodes_in_cell(cell.0, cell.1)
            .filter_map(|j| trav.node(j).map(|m| (j, m)))
            .filter(|(_, m)| (m.ground_z - z).abs() <= p.level_m as f32)
            .min_by(|a, b| {
                (a.1.ground_z - z)
                    .abs()
                    .total_cmp(&(b.1.ground_z - z).abs())
            });
        let Some((j, m)) = on else {
            break;
        };
        if !m.class.is_drivable()
            || obstacle_near(trav, m.ix, m.iy, m.ground_z, clearance_m, &mut work)
        {
            break;
        }
        z = m.ground_z;
        let (u, _) = unseen_under(trav, m.ix, m.iy, m.ground_z, p, &mut work);
        if u == 0 {
            return (j, work);
        }
        if u < best.0 {
            best = (u, j);
        }
    }
    (best.1, work)
}

/// The cells within the body's radius of `(ix, iy)` with no patch of the
/// graph near height `z`, and the sum of the offsets from them to the
/// centre (cells): the way away from them.
fn unseen_under(
    trav: &TravMap,
    ix: i32,
    iy: i32,
    z: f32,
    p: &FirmGoalParams,
    work: &mut u64,
) -> (u32, [f64; 2]) {
    let r = (p.body_radius_m / trav.resolution()).round() as i32;
    let (mut count, mut pull) = (0u32, [0.0f64; 2]);
    for dy in -r..=r {
        for dx in -r..=r {
            if dx * dx + dy * dy > r * r {
                continue;
            }
            *work += 1;
            let seen = trav.nodes_in_cell(ix + dx, iy + dy).any(|j| {
                trav.node(j)
                    .is_some_and(|m| (m.ground_z - z).abs() <= 2.0 * p.level_m as f32)
            });
            if !seen {
                count += 1;
                pull[0] -= dx as f64;
                pull[1] -= dy as f64;
            }
        }
    }
    (count, pull)
}

/// Whether an obstacle patch near height `z` lies within `radius_m`; the
/// cells looked up are added to `work`.
pub(crate) fn obstacle_near(
    trav: &TravMap,
    ix: i32,
    iy: i32,
    z: f32,
    radius_m: f64,
    work: &mut u64,
) -> bool {
    let r = (radius_m / trav.resolution()).round() as i32;
    for dy in -r..=r {
        for dx in -r..=r {
            if dx * dx + dy * dy > r * r {
                continue;
            }
            *work += 1;
            let hit = trav.nodes_in_cell(ix + dx, iy + dy).any(|j| {
                trav.node(j)
                    .is_some_and(|m| m.class == TravClass::Obstacle && (m.ground_z - z).abs() < 0.5)
            });
            if hit {
                return true;
            }
        }
    }
    false
}
