//! `speleo plan --world NAME`: the multi-level planner on a world's
//! ground-truth surface. The mesh is sampled every 5 cm into a multi-level
//! surface map, the traversability map grown from the start, and ARA* run
//! over the rover's primitives projected on it; `speleo world waypoints`
//! names the poses to plan between.

use std::collections::BTreeMap;
use std::fmt;
use std::time::Instant;

use serde::Serialize;
use speleo_mapping::mls::{MlsMap, MlsParams};
use speleo_planner::arastar::Lattice;
use speleo_planner::mprim;
use speleo_planner::primitives::{generate, PrimitiveSpec};
use speleo_planner::sbpl::angle_to_bin;
use speleo_planner::surface::{SurfaceLattice, SurfaceParams};
use speleo_traversability::{TravMap, TravParams};
use speleo_twin::lidar::LidarWorld;
use speleo_twin::world::World;

use super::plan::{search_timed, Round};
use super::Error;

/// Spacing of the points sampled on the mesh, m.
const SAMPLE_M: f64 = 0.05;

/// Named poses of a world: x, y, ground z, yaw.
pub fn waypoints(w: &World) -> Vec<(String, [f64; 4])> {
    let mut out = vec![("start".to_string(), w.start)];
    out.extend(w.named.iter().cloned());
    let r = &w.route;
    if r.len() < 2 {
        return out;
    }
    let yaw_at = |i: usize| {
        let (a, b) = if i + 1 < r.len() {
            (r[i], r[i + 1])
        } else {
            (r[i - 1], r[i])
        };
        (b[1] - a[1]).atan2(b[0] - a[0])
    };
    let pose = |i: usize| [r[i][0], r[i][1], r[i][2], yaw_at(i)];
    out.push(("entrance".into(), pose(0)));
    // Every 10 m along the route.
    let mut along = 0.0;
    let mut next = 10.0;
    for i in 1..r.len() {
        along += ((r[i][0] - r[i - 1][0]).powi(2)
            + (r[i][1] - r[i - 1][1]).powi(2)
            + (r[i][2] - r[i - 1][2]).powi(2))
        .sqrt();
        if along >= next {
            out.push((format!("m{}", next as u32), pose(i)));
            next += 10.0;
        }
    }
    // A level wherever the route settles 1.5 m above or below the last
    // one, over or under another floor (a slope down a cave is no level).
    let stacked = |i: usize| floor_over_or_under(w, r[i]);
    let mut level_z = r[0][2];
    let mut levels = vec![("level0".to_string(), pose(0))];
    for i in 1..r.len() - 1 {
        let flat = (r[i + 1][2] - r[i][2]).abs() < 0.02;
        if flat && (r[i][2] - level_z).abs() > 1.5 && stacked(i) {
            level_z = r[i][2];
            levels.push((format!("level{}", levels.len()), pose(i)));
        }
    }
    if levels.len() > 1 {
        out.extend(levels);
    }
    out
}

/// Whether the world has a floor (a face within 20 degrees of level,
/// facing up) more than 1.5 m above or below `p`.
fn floor_over_or_under(w: &World, p: [f64; 3]) -> bool {
    let m = &w.mesh;
    (0..m.triangles.len()).any(|t| {
        let (_, n) = m.triangle_geometry(t);
        if n[2] < 20f64.to_radians().cos() {
            return false;
        }
        let v = m.triangles[t].map(|i| m.vertices[i as usize].map(f64::from));
        let inside = {
            // Same side of all three edges.
            let side = |a: [f64; 3], b: [f64; 3]| {
                (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
            };
            let s = [side(v[0], v[1]), side(v[1], v[2]), side(v[2], v[0])];
            s.iter().all(|&x| x >= 0.0) || s.iter().all(|&x| x <= 0.0)
        };
        inside && ((v[0][2] + v[1][2] + v[2][2]) / 3.0 - p[2]).abs() > 1.5
    })
}

/// A pose by name, or `x,y,z,yaw` (metres, degrees).
pub fn pose_of(spec: &str, named: &[(String, [f64; 4])]) -> Result<[f64; 4], String> {
    if let Some((_, p)) = named.iter().find(|(n, _)| n == spec) {
        return Ok(*p);
    }
    let v: Vec<f64> = spec
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            let names: Vec<&str> = named.iter().map(|(n, _)| n.as_str()).collect();
            format!(
                "\"{spec}\": not x,y,z,yaw nor a waypoint ({})",
                names.join(", ")
            )
        })?;
    match v[..] {
        [x, y, z, yaw] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z, yaw.to_radians()]),
        _ => Err(format!(
            "\"{spec}\": a pose is x,y,z,yaw (four finite numbers)"
        )),
    }
}

/// The mesh's surface as a multi-level surface map: every point of a face
/// that a sensor could see, sampled on a barycentric grid of `SAMPLE_M`.
/// A point is hidden when the ray along its face's normal, from just in
/// front of it, meets the back of a face first: it lies inside a solid
/// (the buried foot of a ramp, the part of a slab's underside inside
/// another slab). Levels split
/// at 0.2 m rather than the sensor maps' 0.3 m, so that a 0.25 m slab
/// stays a floor over its own underside instead of becoming a wall.
pub fn surface_map(w: &World) -> Result<MlsMap, Error> {
    let mut mls = MlsMap::new(MlsParams {
        max_cells: 1 << 20,
        max_patches_per_cell: 8,
        gap_m: 0.2,
        vertical_threshold_m: 0.15,
        ..MlsParams::default()
    })?;
    let m = &w.mesh;
    let rays = LidarWorld::new(m)?;
    let mut pts = Vec::with_capacity(1 << 16);
    for (k, t) in m.triangles.iter().enumerate() {
        let [a, b, c] = t.map(|i| m.vertices[i as usize].map(f64::from));
        let (_, n) = m.triangle_geometry(k);
        let hidden = |p: [f64; 3]| {
            let front = [0, 1, 2].map(|i| p[i] + 0.02 * n[i]);
            rays.cast_signed(front, n, 1000.0)
                .is_some_and(|(_, facing)| facing > 0.0)
        };
        let len = |p: [f64; 3], q: [f64; 3]| {
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
        };
        let longest = len(a, b).max(len(b, c)).max(len(c, a));
        let steps = ((longest / SAMPLE_M).ceil() as usize).clamp(1, 4096);
        for i in 0..=steps {
            for j in 0..=steps - i {
                let (u, v) = (i as f64 / steps as f64, j as f64 / steps as f64);
                let p = [0, 1, 2].map(|k| a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]));
                if !hidden(p) {
                    pts.push(p);
                }
            }
        }
        if pts.len() > 1 << 16 {
            mls.insert_points(&pts);
            pts.clear();
        }
    }
    mls.insert_points(&pts);
    Ok(mls)
}

#[derive(Serialize, Debug)]
pub struct WorldPlanReport {
    pub world: String,
    pub seed: u64,
    pub start: [f64; 4],
    pub goal: [f64; 4],
    pub mls_cells: usize,
    pub trav_nodes: usize,
    pub trav_traversable: usize,
    pub trav_obstacle: usize,
    pub primitives: usize,
    /// Building the maps, and the lattice with its heuristic, s.
    pub maps_s: f64,
    pub lattice_s: f64,
    /// Mean time of one work unit of each phase, us: a node grown, and a
    /// unit of each lattice preparation phase (the planner task's quanta
    /// are sized from these and `us_per_expansion`).
    pub units_us: BTreeMap<&'static str, f64>,
    pub us_per_expansion: Option<f64>,
    pub heuristic_at_start_ms: u32,
    pub rounds: Vec<Round>,
    pub first_solution_s: Option<f64>,
    pub optimal_s: Option<f64>,
    pub expansions: u64,
    /// Travel time of the optimal plan, ms.
    pub cost_ms: Option<u32>,
    pub path_length_m: f64,
    /// The cells' ground points along the plan.
    pub path: Vec<[f64; 3]>,
}

impl fmt::Display for WorldPlanReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} (seed {}): MLS {} cells, traversability {} nodes ({} traversable, {} obstacle), {} primitives; maps {:.2} s, lattice {:.2} s",
            self.world,
            self.seed,
            self.mls_cells,
            self.trav_nodes,
            self.trav_traversable,
            self.trav_obstacle,
            self.primitives,
            self.maps_s,
            self.lattice_s
        )?;
        let units: Vec<String> = self
            .units_us
            .iter()
            .map(|(k, v)| format!("{k} {v:.1}"))
            .collect();
        writeln!(
            f,
            "work units, us: {}; an expansion {}",
            units.join(", "),
            self.us_per_expansion
                .map_or("-".into(), |v| format!("{v:.1}"))
        )?;
        for r in &self.rounds {
            writeln!(
                f,
                "eps {:.2}: {:.1} s of travel after {} expansions, {:.3} s",
                r.eps,
                r.cost as f64 / 1000.0,
                r.expansions,
                r.time_s
            )?;
        }
        match (self.cost_ms, self.optimal_s) {
            (Some(c), Some(t)) => write!(
                f,
                "optimal: {:.1} s of travel, {:.2} m, proven in {t:.3} s ({} expansions)",
                c as f64 / 1000.0,
                self.path_length_m,
                self.expansions
            ),
            _ => write!(f, "no path ({} expansions)", self.expansions),
        }
    }
}

/// What `speleo plan --world` needs.
pub struct WorldPlanArgs<'a> {
    pub world: &'a str,
    pub seed: u64,
    pub start: &'a str,
    pub goal: &'a str,
    pub mprim: Option<&'a std::path::Path>,
    pub eps: f64,
    pub eps_step: f64,
    pub quantum: u32,
}

pub fn plan_world(a: &WorldPlanArgs<'_>) -> Result<WorldPlanReport, Error> {
    let started = Instant::now();
    let w = World::build(a.world, a.seed)?;
    let named = waypoints(&w);
    let start = pose_of(a.start, &named)?;
    let goal = pose_of(a.goal, &named)?;
    let mls = surface_map(&w)?;
    let mut trav = TravMap::new(TravParams::default())?;
    let grown = Instant::now();
    let stats = trav.build(&mls, [start[0], start[1], start[2]])?;
    let grow_us_per_node = grown.elapsed().as_secs_f64() * 1e6 / stats.nodes.max(1) as f64;
    let maps_s = started.elapsed().as_secs_f64();
    let prims = match a.mprim {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .map_err(|e| format!("cannot read {}: {e}", p.display()))?;
            mprim::parse(&text).map_err(|e| format!("{}: {e}", p.display()))?
        }
        None => generate(&PrimitiveSpec::default()),
    };
    let find = |p: [f64; 4], what: &str| {
        trav.node_at(p[0], p[1], p[2], 0.3)
            .filter(|&i| trav.node(i).is_some_and(|n| n.class.is_drivable()))
            .ok_or_else(|| {
                format!(
                    "the {what} ({:.2}, {:.2}, {:.2}) is not on drivable ground reachable from the start",
                    p[0], p[1], p[2]
                )
            })
    };
    let (s_node, g_node) = (find(start, "start")?, find(goal, "goal")?);
    let started = Instant::now();
    let cells = speleo_planner::surface::grid_cells_for(&trav, &SurfaceParams::default());
    let mut lat = SurfaceLattice::new(trav, &prims, SurfaceParams::default(), cells)?;
    lat.begin((g_node, angle_to_bin(goal[3], prims.angles)))?;
    // Unit by unit, timed per phase: the figures the on-board quanta are
    // calibrated from.
    let mut phases: BTreeMap<&'static str, (f64, u64)> = BTreeMap::new();
    loop {
        let phase = lat.phase();
        let t = Instant::now();
        let done = lat.prepare(&mls, 1);
        let e = phases.entry(phase).or_default();
        e.0 += t.elapsed().as_secs_f64() * 1e6;
        e.1 += 1;
        if done {
            break;
        }
    }
    let mut units_us: BTreeMap<&'static str, f64> = phases
        .into_iter()
        .map(|(k, (us, n))| (k, us / n as f64))
        .collect();
    units_us.insert("grow (a node)", grow_us_per_node);
    let lattice_s = started.elapsed().as_secs_f64();
    let s_state = lat.state(s_node, angle_to_bin(start[3], prims.angles));
    let timed = search_timed(
        &lat,
        s_state,
        lat.goal_state(),
        a.eps,
        a.eps_step,
        a.quantum,
    );
    let (rounds, optimal, states) = (timed.rounds, timed.optimal, timed.states);
    let path = lat.path_positions(&states);
    let path_length_m = path
        .windows(2)
        .map(|w| {
            ((w[1][0] - w[0][0]).powi(2)
                + (w[1][1] - w[0][1]).powi(2)
                + (w[1][2] - w[0][2]).powi(2))
            .sqrt()
        })
        .sum();
    Ok(WorldPlanReport {
        world: a.world.to_string(),
        seed: a.seed,
        start,
        goal,
        mls_cells: mls.stats().cells,
        trav_nodes: stats.nodes,
        trav_traversable: stats.traversable + stats.explorable + stats.frontier,
        trav_obstacle: stats.obstacle,
        primitives: lat.action_count(),
        maps_s,
        lattice_s,
        units_us,
        us_per_expansion: optimal.map(|o| o.1 * 1e6 / timed.expansions.max(1) as f64),
        heuristic_at_start_ms: lat.heuristic(s_state),
        first_solution_s: rounds.first().map(|r| r.time_s),
        optimal_s: optimal.map(|o| o.1),
        expansions: timed.expansions,
        cost_ms: optimal.map(|o| o.0),
        path_length_m,
        path,
        rounds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_garage_has_a_waypoint_per_level_and_poses_parse() {
        let w = World::build("garage", 1).unwrap_or_else(|e| panic!("{e}"));
        let named = waypoints(&w);
        let z = |n: &str| pose_of(n, &named).map(|p| p[2]).unwrap_or(f64::NAN);
        assert_eq!((z("level0"), z("level1"), z("level2")), (0.0, 3.0, 6.0));
        assert!(pose_of("level3", &named).is_err_and(|e| e.contains("level2")));
        let p = pose_of("1, 2, 3, 90", &named).unwrap_or_default();
        assert_eq!(p[..3], [1.0, 2.0, 3.0]);
        assert!((p[3] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!(pose_of("1,2,3", &named).is_err_and(|e| e.contains("four")));
        assert!(pose_of("1,2,nan,0", &named).is_err());
    }

    #[test]
    fn a_cave_sloping_down_has_no_levels() {
        let w = World::build("lava-tube", 1).unwrap_or_else(|e| panic!("{e}"));
        let named = waypoints(&w);
        assert!(named.iter().all(|(n, _)| !n.starts_with("level")));
        assert!(named.iter().any(|(n, _)| n == "m200"));
    }
}
