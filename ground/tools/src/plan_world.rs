//! `speleo plan --world NAME`: the multi-level planner on a world's
//! ground-truth surface. The mesh is sampled every 5 cm into a multi-level
//! surface map, the traversability map grown from the start, and ARA* run
//! over the rover's primitives projected on it; `speleo world waypoints`
//! names the poses to plan between.

use std::collections::BTreeMap;
use std::fmt;
use std::time::Instant;

use serde::Serialize;
use speleo_firmware::truth_map::surface_map;
use speleo_planner::arastar::Lattice;
use speleo_planner::mprim;
use speleo_planner::primitives::{generate, PrimitiveSpec};
use speleo_planner::sbpl::angle_to_bin;
use speleo_planner::surface::{SurfaceLattice, SurfaceParams};
use speleo_traversability::{TravMap, TravParams};
use speleo_twin::world::waypoints::{pose_of, waypoints};
use speleo_twin::world::World;

use crate::plan::{search_timed, Round};
use crate::Error;

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
