//! Ground the LiDAR did not see but the rover will stand on: a strip along
//! the plan and a pad under the rover, each vertex laid just under the
//! seen ground of its column, or at the planner's ground where the scans
//! left a hole.
//!
//! A strip of flat pieces, one per plan pose, floats over the ground it
//! overlaps wherever the ground slopes (plan poses are primitive ends, up
//! to a metre apart): on an 11° slope the next pose's piece stood 0.15 m
//! over the floor behind it, and the legs caught under its edge. Laid on
//! the seen ground, the strip only fills the holes.

use speleo_physics::{Material, Mesh};

use crate::terrain::Terrain;

/// The strip lies this far under the ground it follows, m: where the
/// scans have ground, the mesh carries the rover.
const DROP_M: f64 = 0.03;
/// Samples along the plan at most this far apart, m.
const STEP_M: f64 = 0.2;
/// Vertices across the strip.
const ACROSS: usize = 5;
/// The column is searched from this far over the planner's ground down to
/// this far under it, m: a rock beside the path is found from above, a
/// drop beside it down to its floor.
const SEARCH_UP_M: f64 = 0.25;
const SEARCH_DOWN_M: f64 = 1.0;
/// A miter at a turn is at most this much wider than the strip.
const MAX_MITER: f64 = 2.0;
/// The pad's vertices per side.
const PAD_SIDE: usize = 9;

/// The plane the rover stands on, over the square it stands in: where
/// the scans never see the ground, the rover's own attitude says how it
/// lies. Put down level there, a rover tilted on a side slope stood on a
/// shelf cut into it, far less tilted than it was.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footing {
    /// x, y and the ground's z under base_link.
    pub at: [f64; 3],
    /// Rise per metre along x and y.
    pub slope: [f64; 2],
    /// Half the square's side, m.
    pub half: f64,
}

impl Footing {
    /// The plane's height at `x, y`, inside the square.
    fn z(&self, x: f64, y: f64) -> Option<f64> {
        let (dx, dy) = (x - self.at[0], y - self.at[1]);
        (dx.abs() <= self.half && dy.abs() <= self.half)
            .then(|| self.at[2] + self.slope[0] * dx + self.slope[1] * dy)
    }
}

/// A sample of the strip's centre line: where, the ground the planner
/// found there, and the direction across (unit, scaled by the miter).
struct Sample {
    at: [f64; 2],
    z: f64,
    across: [f64; 2],
}

/// The strip along `path` (x, y, ground z per point, the rover's start
/// first), `half_width` each side of it and `beyond` past both ends;
/// within `footing`, its plane stands for the planner's ground.
pub fn strip(
    terrain: &Terrain,
    path: &[[f64; 3]],
    half_width: f64,
    beyond: f64,
    footing: Option<&Footing>,
) -> Mesh {
    let mut mesh = Mesh::default();
    let samples = centre_line(path, beyond);
    for (i, s) in samples.iter().enumerate() {
        // Drops past an edge are looked for beside level stretches of
        // the plan only (see `over_edge`).
        let level = level_at(&samples, i);
        for k in 0..ACROSS {
            let u = half_width * (2.0 * k as f64 / (ACROSS - 1) as f64 - 1.0);
            let (x, y) = (s.at[0] + u * s.across[0], s.at[1] + u * s.across[1]);
            let z = footing.and_then(|f| f.z(x, y)).unwrap_or(s.z);
            let from = level.then_some(s.at);
            mesh.vertices.push(vertex(terrain, x, y, z, from));
        }
    }
    triangulate_grid(&mut mesh, samples.len(), ACROSS);
    mesh
}

/// A pad over the footing's square: the ground under the rover, which
/// its lowest beam never sees.
pub fn pad(terrain: &Terrain, footing: &Footing) -> Mesh {
    let mut mesh = Mesh::default();
    let n = PAD_SIDE;
    let [x0, y0, z0] = footing.at;
    for i in 0..n {
        for j in 0..n {
            let f = |k: usize| footing.half * (2.0 * k as f64 / (n - 1) as f64 - 1.0);
            let (dx, dy) = (f(i), f(j));
            let z = z0 + footing.slope[0] * dx + footing.slope[1] * dy;
            // No drops past an edge under the pad: round the rover
            // nothing is seen inward, and a drop laid under a rover at a
            // ramp's side had it stuck where it drove off (`over_edge`).
            mesh.vertices
                .push(vertex(terrain, x0 + dx, y0 + dy, z, None));
        }
    }
    triangulate_grid(&mut mesh, n, n);
    mesh
}

/// Rings round the rover where its floor is looked for, m: past the
/// wheels, and out to where the scans of the rover's own position see the
/// ground.
const FLOOR_RINGS_M: [f64; 3] = [0.8, 1.2, 1.6];
const FLOOR_RING_SAMPLES: usize = 16;
/// Columns searched for the floor (the cost of `floor_around`).
pub const FLOOR_SAMPLES: usize = FLOOR_RINGS_M.len() * FLOOR_RING_SAMPLES;
/// The floor is looked for this far over and under the estimate, m.
const FLOOR_SEARCH_M: f64 = 0.25;
/// Fewest seen columns for the floor to count.
const FLOOR_MIN_SAMPLES: usize = 8;

/// The height of the seen floor round `at` (x, y, the estimated ground
/// z): the median of the seen ground on rings round it, within
/// `FLOOR_SEARCH_M` of the estimate (on a plane, opposite samples average
/// to the height at the centre). None where too little of it was seen.
///
/// Why: the ground under the rover is never in its scans, and the pad that
/// stands for it was laid at the estimated height. When SLAM's estimate of
/// the rover sat 11 cm under the floor its older keyframes had mapped (the
/// garage's first level, before a loop closure), the pad made an 11 cm pit
/// round the rover and the simulated rover, turning round on the spot at
/// the start of a retrace, caught its legs on the rim: stuck, again and
/// again, where the real rover turned freely.
pub fn floor_around(terrain: &Terrain, at: [f64; 3], slope: [f64; 2]) -> Option<f64> {
    let mut seen = [0.0f64; FLOOR_SAMPLES];
    let mut n = 0;
    for r in FLOOR_RINGS_M {
        for k in 0..FLOOR_RING_SAMPLES {
            let a = std::f64::consts::TAU * k as f64 / FLOOR_RING_SAMPLES as f64;
            let (dx, dy) = (r * a.cos(), r * a.sin());
            // The plane's rise there, taken off: what is left is the
            // plane's height at the centre.
            let rise = slope[0] * dx + slope[1] * dy;
            let guess = at[2] + rise;
            let (x, y) = (at[0] + dx, at[1] + dy);
            if let Some(z) = terrain.surface_z(x, y, guess + FLOOR_SEARCH_M, guess - FLOOR_SEARCH_M)
            {
                seen[n] = z - rise;
                n += 1;
            }
        }
    }
    if n < FLOOR_MIN_SAMPLES {
        return None;
    }
    let seen = &mut seen[..n];
    seen.sort_by(f64::total_cmp);
    Some(seen[n / 2])
}

/// Two triangles for each cell of the `rows` x `cols` grid of `mesh`'s
/// vertices (row after row), all rock.
fn triangulate_grid(mesh: &mut Mesh, rows: usize, cols: usize) {
    for i in 1..rows {
        for j in 0..cols.saturating_sub(1) {
            let a = ((i - 1) * cols + j) as u32;
            let b = a + cols as u32;
            mesh.triangles.push([a, b, b + 1]);
            mesh.triangles.push([a, b + 1, a + 1]);
        }
    }
    mesh.materials = vec![Material::Rock; mesh.triangles.len()];
}

/// A vertex just under the seen ground of its column. Where the column
/// holds none, under the planner's ground `z`, unless the hole is the
/// shadow of an edge (see [`over_edge`]).
fn vertex(terrain: &Terrain, x: f64, y: f64, z: f64, from: Option<[f64; 2]>) -> [f32; 3] {
    let ground = terrain
        .open_ground_z(x, y, z + SEARCH_UP_M, z - SEARCH_DOWN_M)
        .or_else(|| over_edge(terrain, [x, y], z, from?))
        .unwrap_or(z);
    [x as f32, y as f32, (ground - DROP_M) as f32]
}

/// Steepest stretch of a plan beside which drops past an edge are laid
/// (tan 5°): on a ramp the plane under the plan's lowest ground cuts the
/// ramp itself, and rays down the ramp marked its own columns (a plan
/// down the garage's first ramp was refused, the true one drove it).
const EDGE_LEVEL_SLOPE: f64 = 0.0875;

/// Whether the plan is level at sample `i` (its neighbours' heights).
fn level_at(samples: &[Sample], i: usize) -> bool {
    let (a, b) = (
        &samples[i.saturating_sub(1)],
        &samples[(i + 1).min(samples.len() - 1)],
    );
    let run = (b.at[0] - a.at[0]).hypot(b.at[1] - a.at[1]);
    run > 1e-6 && (b.z - a.z).abs() <= EDGE_LEVEL_SLOPE * run
}

/// Unseen columns are walked this far outward for evidence of a drop, m:
/// no further, for the unseen ground between says nothing of where the
/// drop begins (beside a ramp driven down, seen-through columns past its
/// side 1 m away sank the simulated ramp under the rover).
const EDGE_OUT_M: f64 = 0.3;
/// The walk's step, m (the simulated world's voxel).
const EDGE_STEP_M: f64 = 0.05;
/// Seen ground within this much under the planner's is level ground, m.
const EDGE_LEVEL_M: f64 = 0.1;
/// A seen-through column's ground is looked for this far down, m...
const EDGE_DOWN_M: f64 = 2.0;
/// ...no higher than this under the planner's, m (the rays that marked
/// it ended deeper)...
const SEEN_THROUGH_MIN_M: f64 = 0.3;
/// ...and where none is seen, taken this far under the planner's, m:
/// deeper than a wheel can reach down.
const SEEN_THROUGH_DROP_M: f64 = 1.0;
/// The seen ground's slope inward of a hole is taken over at least this
/// run, m...
const EDGE_SLOPE_BASE_M: f64 = 0.2;
/// ...and explains the rays down through the plane where it reaches to
/// within this of the plane, m.
const EDGE_SLOPE_MARGIN_M: f64 = 0.05;

/// The ground in the unseen column at `at` past the edge of a drop. From
/// the column outward (away from `from`, the strip's centre line), the
/// first column that is either seen ground at the
/// planner's level `z` or a column rays went down through (see
/// `Terrain::seen_through`) decides: level ground, None (the planner's
/// ground stands); seen through, the column lies on the slope from the
/// last seen ground inward down to the seen-through column's ground (a
/// metre under `z` where none is seen). None too where no ground is seen
/// inward, or where the seen ground inward slopes down enough to reach
/// the plane there by itself.
///
/// Why: a slab's edge hides the ground just under it from a sensor on
/// the slab, so the columns past the edge were holes, and the strip laid
/// the planner's level ground there. A plan along the edge
/// of the garage's ramp opening passed the internal simulation while
/// the rover, its outer wheels over the opening, tipped over; the rays
/// into the opening went down past the floor's level there. Seen ground
/// lower beyond a hole says nothing by itself: beside a ramp climbed
/// from the floor it is the floor, and the ramp's unseen side laid
/// sloping down to it tipped the simulated rover off every climb.
fn over_edge(terrain: &Terrain, at: [f64; 2], z: f64, from: [f64; 2]) -> Option<f64> {
    let (dx, dy) = (at[0] - from[0], at[1] - from[1]);
    let out = dx.hypot(dy);
    if out < EDGE_STEP_M {
        return None;
    }
    let dir = [dx / out, dy / out];
    let xy = |t: f64| (at[0] + t * dir[0], at[1] + t * dir[1]);
    let steps = (EDGE_OUT_M / EDGE_STEP_M).round() as usize;
    let (beyond, z_out) = (0..=steps).map(|k| k as f64 * EDGE_STEP_M).find_map(|t| {
        let (x, y) = xy(t);
        if t > 0.0
            && terrain
                .surface_z(x, y, z + SEARCH_UP_M, z - EDGE_LEVEL_M)
                .is_some()
        {
            Some(None)
        } else if terrain.seen_through(x, y, z) {
            let low = terrain.surface_z(x, y, z - EDGE_LEVEL_M, z - EDGE_DOWN_M);
            let low = low.filter(|&g| g < z - SEEN_THROUGH_MIN_M);
            Some(Some((t, low.unwrap_or(z - SEEN_THROUGH_DROP_M))))
        } else {
            None
        }
    })??;
    // The seen ground inward: the first column (no further in than
    // `from`), and one further in for its slope.
    let seen_in = |from_t: f64, to_t: f64| {
        let (a, b) = (
            (from_t / EDGE_STEP_M).ceil() as usize,
            (to_t / EDGE_STEP_M) as usize,
        );
        (a.max(1)..=b).find_map(|k| {
            let t = k as f64 * EDGE_STEP_M;
            let (x, y) = xy(-t);
            terrain
                .surface_z(x, y, z + SEARCH_UP_M, z - SEARCH_DOWN_M)
                .map(|g| (t, g))
        })
    };
    // With nothing seen inward (the pad's vertices round the rover, whose
    // own ground no scan sees), a slope going on down, which the rays
    // down through the plane may have met, cannot be told from a drop:
    // on a ramp's middle, the pad laid as a drop behind the rover tipped
    // the simulated rover over at once, plan after plan.
    let (behind, g1) = seen_in(EDGE_STEP_M, out)?;
    // Ground sloping down outward reaches the plane by itself: the rays
    // that went down through it there met the slope going on, not a drop
    // (past the end of a plan that stops halfway down a ramp).
    if let Some((t2, g2)) = seen_in(behind + EDGE_SLOPE_BASE_M, behind + 3.0 * EDGE_SLOPE_BASE_M) {
        let fall = (g2 - g1) / (t2 - behind);
        if g1 - fall * (behind + beyond) < terrain.through_z() + EDGE_SLOPE_MARGIN_M {
            return None;
        }
    }
    Some(z + (z_out - z) * behind / (behind + beyond))
}

/// Samples along `path`, at most `STEP_M` apart, with `beyond` more at
/// both ends; the ground between two points is interpolated.
fn centre_line(path: &[[f64; 3]], beyond: f64) -> Vec<Sample> {
    // Points closer than a centimetre add nothing but a degenerate turn.
    let mut pts: Vec<[f64; 3]> = Vec::with_capacity(path.len() + 2);
    for p in path {
        if pts
            .last()
            .is_none_or(|q: &[f64; 3]| (p[0] - q[0]).hypot(p[1] - q[1]) > 0.01)
        {
            pts.push(*p);
        }
    }
    let Some(&first) = pts.first() else {
        return Vec::new();
    };
    if pts.len() == 1 {
        // No direction to follow: a square around the point.
        pts.insert(0, [first[0] - beyond, first[1], first[2]]);
        pts.push([first[0] + beyond, first[1], first[2]]);
    } else {
        let d0 = direction(pts[0], pts[1]);
        let n = pts.len();
        let d1 = direction(pts[n - 2], pts[n - 1]);
        let last = pts[n - 1];
        pts.insert(
            0,
            [
                first[0] - beyond * d0[0],
                first[1] - beyond * d0[1],
                first[2],
            ],
        );
        pts.push([last[0] + beyond * d1[0], last[1] + beyond * d1[1], last[2]]);
    }
    let mut out = Vec::new();
    for i in 0..pts.len() - 1 {
        let (a, b) = (pts[i], pts[i + 1]);
        let d = direction(a, b);
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        let n = (len / STEP_M).ceil().max(1.0) as usize;
        for s in 0..n {
            let t = s as f64 / n as f64;
            let across = if s == 0 && i > 0 {
                miter(direction(pts[i - 1], a), d)
            } else {
                [-d[1], d[0]]
            };
            out.push(Sample {
                at: [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])],
                z: a[2] + t * (b[2] - a[2]),
                across,
            });
        }
    }
    let (a, b) = (pts[pts.len() - 2], pts[pts.len() - 1]);
    let d = direction(a, b);
    out.push(Sample {
        at: [b[0], b[1]],
        z: b[2],
        across: [-d[1], d[0]],
    });
    out
}

/// Unit direction from `a` to `b` in x and y.
fn direction(a: [f64; 3], b: [f64; 3]) -> [f64; 2] {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l = dx.hypot(dy).max(1e-9);
    [dx / l, dy / l]
}

/// The direction across a joint between segments along `d0` and `d1`,
/// scaled so the strip keeps its width on both; where the path turns
/// back on itself, across the incoming segment.
fn miter(d0: [f64; 2], d1: [f64; 2]) -> [f64; 2] {
    let (sx, sy) = (d0[0] + d1[0], d0[1] + d1[1]);
    let l = sx.hypot(sy);
    if l < 1e-3 {
        return [-d0[1], d0[0]];
    }
    let (tx, ty) = (sx / l, sy / l);
    // cos of half the turn: the across of the bisector is this much
    // shorter on each segment.
    let c = (tx * d1[0] + ty * d1[1]).max(1.0 / MAX_MITER);
    [-ty / c, tx / c]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_straight_path_is_sampled_with_its_ground_interpolated() {
        let s = centre_line(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.5]], 0.5);
        // 0.5 m before, 1 m along, 0.5 m after: 3 + 5 + 3 samples and the end.
        assert_eq!(s.len(), 12, "{}", s.len());
        assert!((s[0].at[0] + 0.5).abs() < 1e-12);
        assert!((s[11].at[0] - 1.5).abs() < 1e-12);
        let mid = s
            .iter()
            .find(|q| (q.at[0] - 0.6).abs() < 1e-9)
            .expect("a sample at 0.6 m");
        assert!((mid.z - 0.3).abs() < 1e-9, "{}", mid.z);
        assert!(s.iter().all(|q| q.across == [0.0, 1.0]));
    }

    #[test]
    fn a_right_angle_turn_gets_a_mitred_joint() {
        let s = centre_line(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]], 0.0);
        let joint = s
            .iter()
            .find(|q| (q.at[0] - 1.0).abs() < 1e-9 && q.at[1].abs() < 1e-9)
            .expect("a sample at the joint");
        let l = joint.across[0].hypot(joint.across[1]);
        assert!((l - 2f64.sqrt()).abs() < 1e-9, "{l}");
        // Across points to the inside of the left turn: up and to the left.
        assert!(joint.across[0] < 0.0 && joint.across[1] > 0.0);
    }

    #[test]
    fn a_path_that_turns_back_keeps_a_finite_width() {
        let d = miter([1.0, 0.0], [-1.0, 0.0]);
        assert_eq!(d, [-0.0, 1.0]);
    }

    /// A level footing a metre each side of `at`.
    fn level(at: [f64; 3]) -> Footing {
        Footing {
            at,
            slope: [0.0; 2],
            half: 1.0,
        }
    }

    /// Scans of the ground `z(x, y)` from a sensor 1 m over it at the
    /// origin and at x = 3, every 5 cm over 8 m by 4 m.
    fn terrain(z: impl Fn(f64, f64) -> f64) -> Terrain {
        terrain_seen(z, |_, _| true)
    }

    /// As `terrain`, with only the points where `seen` holds.
    fn terrain_seen(z: impl Fn(f64, f64) -> f64, seen: impl Fn(f64, f64) -> bool) -> Terrain {
        let mut t = Terrain::new(&crate::SimulatorParams::default()).expect("terrain");
        t.begin([-2.0, -2.0, -1.5], [6.0, 2.0, 2.5], f64::NEG_INFINITY);
        for ox in [0.0, 3.0] {
            let mut pts = Vec::new();
            for i in 0..160 {
                for j in 0..80 {
                    let (x, y) = (-2.0 + 0.05 * i as f64, -2.0 + 0.05 * j as f64);
                    if seen(x, y) {
                        pts.push([x, y, z(x, y)]);
                    }
                }
            }
            t.integrate([ox, 0.0, z(ox, 0.0) + 1.0], &mut pts, &mut Vec::new());
        }
        t
    }

    #[test]
    fn the_strip_lies_under_seen_ground_and_fills_a_hole_at_the_plan() {
        // An 11° slope up x, and a side slope rising to +y; poses a metre
        // apart, as primitive ends are.
        let z = |x: f64, y: f64| 0.2 * x + 0.1 * y;
        let t = terrain(z);
        let path: Vec<[f64; 3]> = (0..5).map(|i| [i as f64, 0.0, z(i as f64, 0.0)]).collect();
        let m = strip(&t, &path, 0.75, 0.75, None);
        let mut seen = 0;
        for v in &m.vertices {
            let (x, y) = (v[0] as f64, v[1] as f64);
            let under = z(x, y) - v[2] as f64;
            // A flat piece per pose stood up to 0.15 m over this ground.
            assert!(
                under > 0.0 && under < 0.08,
                "{v:?}: {under} under the ground"
            );
            seen += 1;
        }
        assert!(seen > 50, "{seen}");
        // Where the scans have nothing (past x = 6), the planner's ground.
        let far = strip(&t, &[[7.0, 0.0, 1.0], [8.0, 0.0, 1.2]], 0.5, 0.0, None);
        for v in &far.vertices {
            let expect = 1.0 + 0.2 * (v[0] as f64 - 7.0) - DROP_M;
            assert!((v[2] as f64 - expect).abs() < 1e-5, "{v:?}");
        }
    }

    #[test]
    fn a_hole_in_a_slabs_top_is_not_laid_on_the_floor_under_the_slab() {
        // A slab 0.25 m thick, its top at 0.75 m, over x in [1, 5]: seen
        // from a sensor beside it at floor level (its underside and side,
        // and the floor under it), never from above. The strip along its
        // top follows the planner's ground, not the floor 0.75 m down.
        let mut t = Terrain::new(&crate::SimulatorParams::default()).expect("terrain");
        t.begin([-2.0, -2.0, -1.5], [6.0, 2.0, 2.5], f64::NEG_INFINITY);
        let mut pts = Vec::new();
        for i in 0..160 {
            for j in 0..80 {
                let (x, y) = (-2.0 + 0.05 * i as f64, -2.0 + 0.05 * j as f64);
                pts.push([x, y, 0.0]);
                if (1.0..=5.0).contains(&x) {
                    pts.push([x, y, 0.5]);
                }
            }
        }
        for k in 0..5 {
            for j in 0..80 {
                pts.push([1.0, -2.0 + 0.05 * j as f64, 0.5 + 0.05 * k as f64]);
            }
        }
        t.integrate([-1.0, 0.0, 0.3], &mut pts, &mut Vec::new());
        let path = [[2.0, 0.0, 0.75], [4.0, 0.0, 0.75]];
        let m = strip(&t, &path, 0.4, 0.0, None);
        assert!(!m.vertices.is_empty());
        for v in &m.vertices {
            assert!((v[2] as f64 - (0.75 - DROP_M)).abs() < 1e-5, "{v:?}");
        }
        // The floor beside the slab, with nothing over it, is still found.
        let floor = strip(&t, &[[-1.5, -1.0, 0.0], [-1.5, 1.0, 0.0]], 0.3, 0.0, None);
        for v in &floor.vertices {
            assert!((v[2] as f64 + DROP_M).abs() < 0.05, "{v:?}");
        }
    }

    /// A floor at 0 up to x = 2, seen from a sensor 1 m over the origin;
    /// past it, `beyond(x)` from x = 4 on (the edge hides x = 2..4 when
    /// it lies a metre down), nothing between. Rays down through 0.15 m
    /// under the floor are counted, as for a plan on the floor.
    fn edge_scene(beyond: impl Fn(f64) -> f64) -> Terrain {
        let mut t = Terrain::new(&crate::SimulatorParams::default()).expect("terrain");
        t.begin([-2.0, -2.0, -1.5], [6.0, 2.0, 2.5], -0.15);
        let mut pts = Vec::new();
        for i in 0..160 {
            for j in 0..80 {
                let (x, y) = (-2.0 + 0.05 * i as f64, -2.0 + 0.05 * j as f64);
                if x < 2.0 {
                    pts.push([x, y, 0.0]);
                } else if x >= 4.0 {
                    pts.push([x, y, beyond(x)]);
                }
            }
        }
        t.integrate([0.0, 0.0, 1.0], &mut pts, &mut Vec::new());
        t
    }

    /// The strip along the edge of `edge_scene`, 0.4 m in from it; the
    /// height of its outer vertices (0.2 m past the edge).
    fn outer_edge_vertices(t: &Terrain) -> Vec<f64> {
        let path = [[1.6, -1.0, 0.0], [1.6, 1.0, 0.0]];
        let m = strip(t, &path, 0.6, 0.0, None);
        m.vertices
            .iter()
            .filter(|v| (v[0] - 2.2).abs() < 1e-3 && v[1].abs() < 0.8)
            .map(|v| v[2] as f64)
            .collect()
    }

    #[test]
    fn past_an_edge_the_rays_went_down_through_the_strip_drops() {
        let t = edge_scene(|_| -1.0);
        assert!(t.seen_through(2.5, 0.0, 0.0));
        assert!(!t.seen_through(1.5, 0.0, 0.0));
        let outer = outer_edge_vertices(&t);
        assert!(!outer.is_empty());
        for z in outer {
            assert!(z < -0.3, "{z}: the strip stood over the drop");
        }
    }

    #[test]
    fn past_a_hole_in_level_ground_the_strip_stays_level() {
        // The same hole (x = 2..4), the floor seen at its level beyond:
        // nothing went down, the planner's ground stands.
        let t = edge_scene(|_| 0.0);
        assert!(!t.seen_through(2.5, 0.0, 0.0));
        for z in outer_edge_vertices(&t) {
            assert!((z + DROP_M).abs() < 1e-6, "{z}");
        }
    }

    #[test]
    fn a_slope_going_on_down_past_the_plan_is_no_drop() {
        // Ground falling 0.25 per metre from x = 0 on (a ramp), seen
        // except for a hole round x = 2.2..2.4 beside the plan; the plan
        // ends at x = 1.6, its lowest ground there (-0.4), so the ramp
        // goes under the plane 0.15 m below from x = 2.2.
        let z = |x: f64| -0.25 * x.max(0.0);
        let mut t = Terrain::new(&crate::SimulatorParams::default()).expect("terrain");
        t.begin([-2.0, -2.0, -2.5], [6.0, 2.0, 2.5], z(1.6) - 0.15);
        let mut pts = Vec::new();
        for i in 0..160 {
            for j in 0..80 {
                let (x, y) = (-2.0 + 0.05 * i as f64, -2.0 + 0.05 * j as f64);
                if !(2.15..2.45).contains(&x) {
                    pts.push([x, y, z(x)]);
                }
            }
        }
        t.integrate([0.0, 0.0, 1.0], &mut pts, &mut Vec::new());
        assert!(
            t.seen_through(2.5, 0.0, z(1.6)),
            "the ramp passes the plane"
        );
        let path = [[1.6, -1.0, z(1.6)], [1.6, 1.0, z(1.6)]];
        let m = strip(&t, &path, 0.7, 0.0, None);
        for v in m.vertices.iter().filter(|v| (v[0] - 2.3).abs() < 1e-3) {
            assert!(v[2] as f64 > z(1.6) - 0.1, "{v:?}: sunk into the ramp");
        }
    }

    #[test]
    fn the_pad_follows_the_seen_ground_around_the_rover() {
        let z = |x: f64, _: f64| 0.2 * x;
        let t = terrain(z);
        let m = pad(&t, &level([1.0, 0.0, 0.2]));
        assert_eq!(m.vertices.len(), PAD_SIDE * PAD_SIDE);
        for v in &m.vertices {
            let under = z(v[0] as f64, 0.0) - v[2] as f64;
            assert!(under > 0.0 && under < 0.08, "{v:?}: {under}");
        }
    }

    #[test]
    fn the_floor_round_the_rover_is_the_seen_one_not_the_estimate() {
        // A floor 11 cm over the estimate (SLAM's estimate of the rover
        // sank), and a slope: the median of the rings is the height at the
        // centre.
        let flat = terrain(|_, _| 0.11);
        let f = floor_around(&flat, [1.5, 0.0, 0.0], [0.0; 2]).expect("seen floor");
        assert!((f - 0.11).abs() < 0.03, "{f}");
        let slope = terrain(|x, _| 0.1 * x);
        let f = floor_around(&slope, [1.5, 0.0, 0.12], [0.0; 2]).expect("seen floor");
        assert!((f - 0.15).abs() < 0.03, "{f}");
        // Nothing within the search window: no answer.
        assert!(floor_around(&flat, [1.5, 0.0, 0.6], [0.0; 2]).is_none());
    }

    #[test]
    fn the_pad_laid_at_the_seen_floor_has_no_pit() {
        // Nothing seen within 0.6 m of the rover, as from its own mast.
        let t = terrain_seen(|_, _| 0.11, |x, y| (x - 1.5).hypot(y) > 0.6);
        let low = pad(&t, &level([1.5, 0.0, 0.0]));
        let f = floor_around(&t, [1.5, 0.0, 0.0], [0.0; 2]).expect("floor");
        let level = pad(&t, &level([1.5, 0.0, f]));
        let lowest = |m: &Mesh| m.vertices.iter().map(|v| v[2]).fold(f32::MAX, f32::min);
        let highest = |m: &Mesh| m.vertices.iter().map(|v| v[2]).fold(f32::MIN, f32::max);
        // At the estimate the unseen middle lies lower than the seen rim...
        assert!(highest(&low) - lowest(&low) > 0.05);
        // ...at the seen floor it does not.
        assert!(highest(&level) - lowest(&level) < 0.03);
    }

    #[test]
    fn under_a_tilted_rover_the_floor_and_the_pad_follow_its_tilt() {
        // A 27° side slope, nothing seen within 0.6 m of the rover: laid
        // level, the hole under it would be a flat shelf cut into the
        // slope, and the simulated rover would stand level on it.
        let z = |_: f64, y: f64| 0.5 * y;
        let t = terrain_seen(z, |x, y| (x - 1.5).hypot(y) > 0.6);
        let slope = [0.0, 0.5];
        let f = floor_around(&t, [1.5, 0.0, 0.05], slope).expect("seen floor");
        assert!(f.abs() < 0.03, "{f}");
        let footing = Footing {
            at: [1.5, 0.0, f],
            slope,
            half: 1.0,
        };
        let m = pad(&t, &footing);
        for v in &m.vertices {
            let under = z(v[0] as f64, v[1] as f64) - v[2] as f64;
            assert!(
                under > -0.03 && under < 0.1,
                "{v:?}: {under} under the slope"
            );
        }
    }
}
