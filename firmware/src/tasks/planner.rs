//! The planner as an anytime task. Every `replan_every_s` it takes the
//! SLAM pose and the point `goal_ahead_m` ahead along the route, then in
//! fixed quanta of work: grows the traversability graph over the serving
//! MLS map within a window around the rover, picks the start and goal
//! nodes, prepares the lattice (cell index, body checks, the cost-to-go)
//! and runs ARA*, publishing the first plan as soon as it exists and each
//! better one as epsilon falls. Each step does one phase's work for one
//! quantum, so the same inputs give the same plans at the same frames on
//! any machine.
//!
//! With exploration on, the goals are the exploration's instead
//! (`tasks::exploration`): a query begins when the last traverse is over,
//! scans the graph for candidates after picking the start, and plans to
//! them in turn until one has a path; that plan is marked to be driven.
//!
//! Every buffer (graph, lattice, search, plan) is taken at start-up for
//! `planner.max_nodes` nodes and the window's cells: nothing is allocated
//! while planning.

use speleo_mapping::mls::{ground_near, MlsMap};
use speleo_planner::arastar::{AraParams, AraStar, Lattice, Progress};
use speleo_planner::mprim::MprimFile;
use speleo_planner::surface::{SurfaceLattice, SOLID_PER_CELL};
use speleo_scheduler::histogram::Histogram;
use speleo_scheduler::realtime::thread_cpu_ns;
use speleo_scheduler::{Context, StepResult, Task};
use speleo_traversability::{TravMap, Window};

use speleo_exploration::{Mode, Pass, ReturnReason};
use speleo_simulator::{Outcome, Stance};

use crate::bus::Bus;
use crate::config::PlannerConfig;
use crate::tasks::control::yaw_of;
use crate::tasks::exploration::{
    Exploration, NO_GO_RADIUS_M, RIM_RADIUS_M, SLIDE_RADIUS_M, SLIDE_RISE_M,
};
use speleo_messages::PlanMsg;

/// Results kept for the report's medians (a query every few seconds: days
/// of mission).
const HISTORY: usize = 8192;
/// Start patches tried, nearest the rover first.
const START_CANDIDATES: usize = 8;
/// How far from the rover the start patch may be (the LiDAR does not see
/// the ground right under the rover until it has moved), m.
const START_REACH_M: f64 = 1.5;

/// Nodes this near the rover stay drivable inside a no-go place (the
/// query must start from somewhere), m.
const NO_GO_SPARE_M: f64 = 0.3;
/// How far from the point ahead on the route the goal node may be, m.
const GOAL_REACH_M: f64 = 1.0;
/// How far above or below the rover its start node, and a goal point that
/// has a height (a point of the track home) its goal node, may lie, m: on
/// the garage's way home, the track's point on level 1 took the node over
/// it on level 2, and the rover drove back up the ramp it had just come
/// down, again and again.
const LEVEL_M: f64 = 1.0;
/// Where the map does not reach `goal_ahead_m` yet, the goal comes back
/// along the route a metre at a time, to no nearer than this, m.
const GOAL_NEAREST_M: f64 = 2.0;
const GOAL_POINTS: usize = 32;
/// Work units, each about one ARA* expansion (~10 us; see the planner
/// README): the traversability graph's growth work (about two nodes on
/// open floor: `TravMap::grow` counts cells and patches read and points
/// fitted), nodes scanned for the start and the goal.
const GROW_PER_UNIT: u64 = 800;
const PICK_PER_UNIT: usize = 128;
/// Candidate scan work per unit: nodes looked at and cells looked up
/// around candidates (a candidate looks at ~110 cells, most nodes at none).
const SCAN_PER_UNIT: u64 = 128;
/// Exploring, the rover waits for its plan: a goal without a path after
/// this many expansions is given up for the next candidate, and a plan
/// not proven optimal this many expansions after the first is driven as it
/// is (its bound is in the plan).
const EXPLORE_GOAL_EXPANSIONS: u64 = 40_000;

/// A query that drove nothing grows the next one's window by this factor.
const WINDOW_GROWTH: f64 = 1.5;
const EXPLORE_IMPROVE_EXPANSIONS: u64 = 20_000;

/// What the task has done.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlannerCounters {
    /// Queries begun (every kind of end below counts one).
    pub queries: u64,
    /// No ground patch near the rover, or none drivable.
    pub no_start: u64,
    /// No drivable node near the point ahead on the route.
    pub no_goal: u64,
    /// The goal cannot be reached within the window.
    pub no_path: u64,
    /// At least one plan published.
    pub solved: u64,
    /// Proven optimal.
    pub optimal: u64,
    /// Stopped at `max_expansions` with the best plan so far.
    pub abandoned: u64,
    pub expansions: u64,
    pub plans_published: u64,
    /// Largest graph grown, and graphs that hit `max_nodes`.
    pub nodes_max: u64,
    pub graphs_full: u64,
    /// Queries skipped because the lattice refused the graph (a window
    /// larger than configured, which validation prevents).
    pub lattice_errors: u64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    Idle,
    /// Growing the graph from start candidate `candidate`.
    Grow {
        candidate: usize,
    },
    /// Scanning the nodes for the start and the goal, from node `next`.
    Pick {
        next: usize,
    },
    /// Scanning the graph for exploration candidates.
    Candidates,
    Prepare,
    Search,
    /// Driving the plan in the internal simulator.
    Validate,
    /// No goal passed the simulation: driving the longest well-driven
    /// first part of a refused plan.
    Partial,
}

/// The query under way.
#[derive(Clone, Copy, Debug, Default)]
struct Query {
    began_ns: u64,
    rover: [f64; 3],
    yaw: f64,
    /// The rover's attitude (w, x, y, z): the internal simulation starts
    /// it as it stands.
    attitude: [f64; 4],
    /// Points along the route, farthest first (with the route's heading
    /// there).
    goals: [([f64; 2], f64); GOAL_POINTS],
    /// The height of each goal point where it has one (the track's).
    goal_z: [Option<f64>; GOAL_POINTS],
    goal_count: usize,
    /// The start node and, per goal point, the node found so far, with
    /// their distances².
    start: Option<(u32, f64)>,
    goal: [Option<(u32, f64)>; GOAL_POINTS],
    start_state: u32,
    /// Goal nodes to try in turn and their positions, and the one tried.
    order: [(u32, [f64; 3]); GOAL_POINTS],
    order_len: usize,
    tried: usize,
    solved: bool,
    /// Proven bound of the last plan, thousandths, and its cost.
    eps_milli: u32,
    cost: u32,
    /// Expansions when the first plan was found.
    solved_at: u64,
    /// The plan under validation: its (cost, bound) and optimality.
    best: ((u32, u32), bool),
    /// The plan under validation is a retrace of the track.
    retrace: bool,
}

pub struct PlannerTask {
    lat: SurfaceLattice,
    /// Cells of the lattice's map table.
    grid_cells: usize,
    search: AraStar,
    params: AraParams,
    route: Vec<[f64; 2]>,
    looped: bool,
    /// Exploration's goals instead of the route's.
    explore: Option<Box<Exploration>>,
    /// Half the side of the growth window now, as configured, and at most.
    window_half_m: f64,
    window_base_half_m: f64,
    window_max_half_m: f64,
    goal_ahead_m: f64,
    replan_ns: u64,
    max_expansions: u64,
    /// The ground under base_link is about this far down, m.
    base_height_m: f64,
    phase: Phase,
    query: Query,
    next_query_ns: u64,
    candidates: heapless::Vec<(i32, i32, f32), START_CANDIDATES>,
    /// Scratch: the plan's states.
    states: Vec<u32>,
    /// Per solved query: mission time to the first plan and, when proven,
    /// to the optimum, ms; the final bound, thousandths.
    pub first_ms: Vec<u32>,
    pub optimal_ms: Vec<u32>,
    pub final_eps_milli: Vec<u32>,
    pub counters: PlannerCounters,
    /// Each phase's step times (by [`PHASE_NAMES`]), for calibrating its
    /// units: measured only, never acted on, so outputs stay the same.
    pub step_times: [Histogram; PHASE_NAMES.len()],
    /// The same steps on the thread's CPU clock (preemption left out).
    pub step_cpu_times: [Histogram; PHASE_NAMES.len()],
    /// Units a step of each phase does (`planner.step_units`)...
    step_units: [u32; PHASE_NAMES.len()],
    /// ...and did, capped by the scheduler's quantum (0: no step yet).
    pub step_units_run: [u32; PHASE_NAMES.len()],
}

/// A step this long on the thread's CPU clock is logged (debug), ns.
const SLOW_STEP_NS: u64 = 1_000_000;

/// The phases whose steps are timed, in [`PlannerTask::step_times`] order.
pub use crate::config::STEP_PHASES as PHASE_NAMES;

impl Phase {
    fn timed_index(self) -> Option<usize> {
        match self {
            Phase::Idle => None,
            Phase::Grow { .. } => Some(0),
            Phase::Pick { .. } => Some(1),
            Phase::Candidates => Some(2),
            Phase::Prepare => Some(3),
            Phase::Search => Some(4),
            Phase::Validate => Some(5),
            Phase::Partial => None,
        }
    }
}

impl PlannerTask {
    /// The task as `[planner]` configures it, following `route` (the
    /// control path), with primitives `prims` at `resolution_m`.
    pub fn new(
        cfg: &PlannerConfig,
        prims: &MprimFile,
        resolution_m: f64,
        route: &[[f64; 2]],
        looped: bool,
        base_height_m: f64,
    ) -> Result<Self, String> {
        let side = (cfg.window_max_m / resolution_m).ceil() as usize + 2;
        let trav = TravMap::new(speleo_traversability::TravParams {
            max_window_cells: side * side,
            ..cfg.trav_params()
        })
        .map_err(|e| e.to_string())?;
        let grid_cells = cfg.window_cells(resolution_m);
        let lat = SurfaceLattice::new(trav, prims, cfg.surface_params(), grid_cells)?;
        if (prims.resolution_m - resolution_m).abs() > 1e-6 * resolution_m {
            return Err(format!(
                "the primitives are for {} m cells, the map has {resolution_m} m",
                prims.resolution_m
            ));
        }
        let search = AraStar::new(lat.max_state_count(), lat.max_successors());
        Ok(PlannerTask {
            grid_cells,
            lat,
            search,
            params: AraParams {
                initial_eps: cfg.initial_eps,
                eps_step: cfg.eps_step,
            },
            route: route.to_vec(),
            looped,
            explore: None,
            window_half_m: cfg.window_m / 2.0,
            window_base_half_m: cfg.window_m / 2.0,
            window_max_half_m: cfg.window_max_m / 2.0,
            goal_ahead_m: cfg.goal_ahead_m,
            replan_ns: (cfg.replan_every_s * 1e9) as u64,
            max_expansions: cfg.max_expansions,
            base_height_m,
            phase: Phase::Idle,
            query: Query::default(),
            next_query_ns: 0,
            candidates: heapless::Vec::new(),
            states: Vec::with_capacity(8192),
            first_ms: Vec::with_capacity(HISTORY),
            optimal_ms: Vec::with_capacity(HISTORY),
            final_eps_milli: Vec::with_capacity(HISTORY),
            counters: PlannerCounters::default(),
            step_times: std::array::from_fn(|_| Histogram::new()),
            step_cpu_times: std::array::from_fn(|_| Histogram::new()),
            step_units: cfg.step_units.as_array(),
            step_units_run: [0; PHASE_NAMES.len()],
        })
    }

    /// Take the exploration's goals instead of the route's.
    pub fn with_exploration(mut self, mut e: Exploration) -> Self {
        e.set_base_height(self.base_height_m);
        self.explore = Some(Box::new(e));
        self
    }

    pub fn exploration(&self) -> Option<&Exploration> {
        self.explore.as_deref()
    }

    /// The search's and the lattice's fixed storage, approximately.
    pub fn memory_bytes(&self, max_nodes: usize) -> usize {
        // Per state: query mark, g, parent, two round marks, heap position
        // (4 bytes each), a heap entry (16) and an INCONS slot (4).
        let search = self.lat.max_state_count() * 44;
        // Per node: the graph's node (~72), index links and the lattice's
        // per-node arrays (~20), eight queue entries (8 each); per cell of
        // the window, the map table's intervals.
        // The graph's heads over its window, 4 bytes a cell.
        let heads = self.lat.trav().params().max_window_cells * 4;
        search + max_nodes * (72 + 20 + 64) + self.grid_cells * 8 * SOLID_PER_CELL + heads
    }

    /// Begin a query if one is due and possible.
    fn begin_query(&mut self, bus: &mut Bus, now: u64) -> bool {
        let Some(pose) = bus.slam.get().map(|p| p.value) else {
            return false;
        };
        match &mut self.explore {
            Some(ex) => {
                if !ex.ready(bus, now) {
                    return false;
                }
                if ex.retrace_due() {
                    // No plan home from here: back the way the rover came.
                    self.counters.queries += 1;
                    let check = ex.retrace(bus, now, self.counters.queries, self.goal_ahead_m);
                    self.counters.plans_published += 1;
                    return check && self.validate_retrace(bus, now, &pose);
                }
            }
            None => {
                if now < self.next_query_ns || self.route.len() < 2 {
                    return false;
                }
            }
        }
        let mls = bus.surface.serving();
        if mls.stats().cells == 0 {
            return false;
        }
        self.next_query_ns = now + self.replan_ns;
        self.counters.queries += 1;
        let segment = bus.command.get().map_or(0, |c| c.value.segment as usize);
        self.query = Query {
            began_ns: now,
            rover: pose.position,
            yaw: yaw_of(pose.orientation),
            attitude: pose.orientation,
            ..Query::default()
        };
        if let Some(ex) = &self.explore {
            // Exploring: candidates come after the graph is grown.
            if matches!(ex.mode(), Mode::Returning(_)) {
                let q = &mut self.query;
                ex.explorer.home_goals(
                    pose.position,
                    self.goal_ahead_m,
                    GOAL_NEAREST_M,
                    &mut |g| {
                        if q.goal_count < GOAL_POINTS {
                            q.goals[q.goal_count] = ([g[0], g[1]], 0.0);
                            q.goal_z[q.goal_count] = Some(g[2]);
                            q.goal_count += 1;
                        }
                    },
                );
            }
        }
        let mut ahead = self.goal_ahead_m;
        while self.explore.is_none() && self.query.goal_count < GOAL_POINTS {
            self.query.goals[self.query.goal_count] = point_ahead(
                &self.route,
                self.looped,
                segment,
                [pose.position[0], pose.position[1]],
                ahead,
            );
            self.query.goal_count += 1;
            ahead -= 1.0;
            if ahead < GOAL_NEAREST_M {
                break;
            }
        }
        start_candidates(
            mls,
            pose.position,
            self.base_height_m,
            self.lat.trav().params().max_step_m as f64,
            &mut self.candidates,
        );
        self.begin_growth(bus.surface.serving(), 0)
    }

    /// Grow from start candidate `k` (or the next that has ground).
    fn begin_growth(&mut self, mls: &MlsMap, mut k: usize) -> bool {
        let [x, y, _] = self.query.rover;
        let res = mls.params().resolution_m;
        let window = Window::around(x, y, self.window_half_m, res);
        while let Some(&(ix, iy, z)) = self.candidates.get(k) {
            let at = [(ix as f64 + 0.5) * res, (iy as f64 + 0.5) * res, z as f64];
            if self.lat.trav_mut().begin(mls, at, Some(window)).is_ok() {
                self.phase = Phase::Grow { candidate: k };
                return true;
            }
            k += 1;
        }
        self.counters.no_start += 1;
        if let Some(ex) = &mut self.explore {
            tracing::debug!(x, y, candidates = k, "no ground to grow the graph from");
            ex.no_start();
        }
        self.end_query();
        false
    }

    /// The query is over: keep its figures and wait for the next.
    fn end_query(&mut self) {
        if self.query.solved && self.final_eps_milli.len() < HISTORY {
            self.final_eps_milli.push(self.query.eps_milli);
        }
        if let Some(ex) = &mut self.explore {
            ex.query_over();
            ex.partial.clear();
            // Nothing driven from here: look farther next time (the way
            // to what is left may start outside the window).
            self.window_half_m = if ex.executing == self.counters.queries {
                self.window_base_half_m
            } else {
                (self.window_half_m * WINDOW_GROWTH).min(self.window_max_half_m)
            };
        }
        self.phase = Phase::Idle;
    }

    /// Nearest drivable nodes to the rover and to the goal point.
    fn pick(&mut self, from: usize, units: usize) -> Phase {
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
                ex.mode(),
                Mode::Exploring | Mode::Returning(ReturnReason::Explored)
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
    fn goal_order(&mut self) -> Phase {
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

    /// Scan the graph for exploration candidates; then plan to the best.
    fn candidates(&mut self, units: usize) -> Phase {
        let Some(ex) = self.explore.as_deref_mut() else {
            return Phase::Idle;
        };
        let Exploration {
            explorer,
            scan,
            counters,
            ..
        } = ex;
        let done = scan.step(
            self.lat.trav(),
            explorer.coverage(),
            explorer.rejected(),
            (units as u64).saturating_mul(SCAN_PER_UNIT),
        );
        if !done {
            return Phase::Candidates;
        }
        // Nothing with room to spare: the tight places (a squeeze's waist),
        // then the crests just over the rover, before giving up here.
        if scan.best().is_empty() && scan.next_pass() {
            return Phase::Candidates;
        }
        if scan.pass() == Pass::Crest {
            if let Some(c) = scan.best().first() {
                tracing::debug!(
                    x = c.position[0],
                    y = c.position[1],
                    z = c.position[2],
                    "a crest to look over"
                );
            }
        }
        counters.scans += 1;
        let found = !scan.best().is_empty();
        if !found
            && explorer.mode() == Mode::Exploring
            && self.window_half_m < self.window_max_half_m
        {
            // Nothing here yet: the next query looks farther before the
            // rover turns back (at a garage ramp's top, the retrace drove
            // it back down).
            counters.scans_empty += 1;
            tracing::debug!(
                x = self.query.rover[0],
                y = self.query.rover[1],
                window_m = 2.0 * self.window_half_m,
                "no candidate in the window"
            );
            self.end_query();
            return Phase::Idle;
        }
        if matches!(explorer.mode(), Mode::Returning(_)) {
            // Nothing new here either (or a return for the time limit, or
            // a place where exploring again was in vain): on home.
            if !found || !explorer.resume([self.query.rover[0], self.query.rover[1]]) {
                return self.goal_order();
            }
            counters.resumes += 1;
            tracing::debug!(
                x = self.query.rover[0],
                y = self.query.rover[1],
                "exploring again"
            );
        } else {
            explorer.query_result(found);
            if explorer.mode() == Mode::Returning(ReturnReason::Explored) && ex.second_look() {
                // The next query grows its graph without the barred places.
                self.end_query();
                return Phase::Idle;
            }
        }
        let rover = [self.query.rover[0], self.query.rover[1]];
        if ex.scan.best().is_empty() && ex.explorer.resumed_in_vain(rover) {
            // Exploring again found nothing here after all: the next
            // query goes home.
            self.end_query();
            return Phase::Idle;
        }
        let best = ex.scan.best();
        if best.is_empty() {
            ex.counters.scans_empty += 1;
            let c = ex.scan.census();
            tracing::debug!(
                x = self.query.rover[0],
                y = self.query.rover[1],
                nodes = self.lat.trav().nodes().len(),
                inner = c.inner,
                beyond_margin = c.beyond_margin,
                too_near = c.too_near,
                covered = c.covered,
                rejected = c.rejected,
                cramped = c.cramped,
                no_crest = c.no_crest,
                crest_not_border = c.crest_not_border,
                crest_low = c.crest_low,
                crest_out_of_reach = c.crest_out_of_reach,
                crest_stood = c.crest_stood,
                farthest_m = c.farthest_m,
                farthest_x = c.farthest[0],
                farthest_y = c.farthest[1],
                "no candidate"
            );
            trace_graph_near(self.lat.trav(), self.query.rover, GRAPH_TRACE_RADIUS_M);
            ex.no_start();
            self.counters.no_goal += 1;
            self.end_query();
            return Phase::Idle;
        }
        let q = &mut self.query;
        q.order_len = best.len().min(GOAL_POINTS);
        for (o, c) in q.order.iter_mut().zip(best) {
            *o = (c.node, c.position);
        }
        self.try_goal(0)
    }

    /// Plan to the `k`-th goal in order (any heading at the goal: the next
    /// query starts from wherever the rover is by then).
    fn try_goal(&mut self, k: usize) -> Phase {
        let partial = self
            .explore
            .as_ref()
            .is_some_and(|ex| !ex.partial.poses.is_empty() && ex.mode() == Mode::Exploring);
        if k >= self.query.order_len && partial {
            return Phase::Partial;
        }
        if k >= self.query.order_len {
            self.counters.no_path += 1;
            if let Some(ex) = &mut self.explore {
                // No goal reachable right after exploring resumed on the
                // way home: home (the next query), not a way on.
                let rover = [self.query.rover[0], self.query.rover[1]];
                if !ex.explorer.resumed_in_vain(rover) {
                    ex.home_failed();
                }
            }
            self.end_query();
            return Phase::Idle;
        }
        self.query.tried = k;
        let (start, _) = self.lat.decode(self.query.start_state);
        self.lat.set_escape(Some(start));
        if let Some(ex) = &mut self.explore {
            ex.counters.goals_attempted += 1;
            let at = self.query.order[k].1;
            tracing::debug!(
                mode = ?ex.mode(),
                from_x = self.query.rover[0],
                from_y = self.query.rover[1],
                x = at[0],
                y = at[1],
                "goal tried"
            );
        }
        if self.lat.begin_any_heading(self.query.order[k].0).is_err() {
            self.counters.lattice_errors += 1;
            self.end_query();
            return Phase::Idle;
        }
        Phase::Prepare
    }

    /// No goal of the query passed the simulation, but a refused plan's
    /// first part was driven well: drive that.
    fn drive_partial(&mut self, bus: &mut Bus, now: u64) {
        let Some(ex) = self.explore.as_deref_mut() else {
            self.end_query();
            return;
        };
        ex.counters.partial_plans += 1;
        tracing::debug!(
            length_m = ex.partial.length_m,
            goal_x = ex.partial.goal[0],
            goal_y = ex.partial.goal[1],
            "driving the part of a refused plan the simulation drove"
        );
        let msg = PlanMsg {
            query: self.counters.queries,
            cost_ms: 0,
            eps: self.query.eps_milli as f32 / 1000.0,
            optimal: false,
            execute: true,
            poses: ex.partial.poses.clone(),
        };
        self.counters.plans_published += 1;
        ex.driving(msg.query);
        ex.compare_partial(msg.query);
        bus.exploration.goal = ex
            .partial
            .poses
            .last()
            .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64]);
        bus.plan.publish(now, msg);
        self.end_query();
    }

    /// Whether the exploration goal being tried stands over a rock (see
    /// `CandidateParams::max_rock_m`, and the planner's `max_bump_m`, which
    /// no path would pass): then it is refused, its place rejected, and
    /// the next goal tried.
    fn goal_on_a_rock(&mut self) -> bool {
        let Some(ex) = self.explore.as_deref_mut() else {
            return false;
        };
        if ex.mode() != Mode::Exploring {
            return false;
        }
        let max_m = ex.scan.params().max_rock_m;
        let (node, at) = self.query.order[self.query.tried];
        let barred = self.lat.over_a_rock(node);
        if max_m <= 0.0 && !barred {
            return false;
        }
        let rock_m = self.lat.rock_m(node).unwrap_or(0.0) as f64;
        if !barred && rock_m <= max_m {
            return false;
        }
        tracing::debug!(x = at[0], y = at[1], rock_m, "a rock under the goal");
        ex.counters.goals_on_rocks += 1;
        ex.explorer.reject([at[0], at[1]]);
        self.phase = self.try_goal(self.query.tried + 1);
        true
    }

    /// No path to the goal tried (`why`, for the log): the next one, or
    /// the query is over.
    fn goal_failed(&mut self, why: &'static str) {
        let Some(ex) = &mut self.explore else {
            self.counters.no_path += 1;
            self.end_query();
            return;
        };
        tracing::debug!(
            why,
            expansions = self.search.stats().expansions,
            window_m = 2.0 * self.window_half_m,
            "no path to the goal"
        );
        ex.counters.goals_unreachable += 1;
        let at = self.query.order[self.query.tried].1;
        // Only a window as large as it gets proves a goal out of reach:
        // the way to it may leave a smaller one (from the far side of a
        // garage level, the way onto the ramp whose top was the goal).
        if ex.mode() == Mode::Exploring && self.window_half_m >= self.window_max_half_m {
            ex.explorer.reject([at[0], at[1]]);
        }
        self.phase = self.try_goal(self.query.tried + 1);
    }

    /// Publish the best plan so far.
    fn publish(
        &mut self,
        bus: &mut Bus,
        now: u64,
        (cost, eps_milli): (u32, u32),
        optimal: bool,
        execute: bool,
    ) {
        self.search.path(&mut self.states);
        let trav = self.lat.trav();
        let bin = std::f64::consts::TAU / self.lat.angles() as f64;
        let mut msg = PlanMsg {
            query: self.counters.queries,
            cost_ms: cost,
            eps: eps_milli as f32 / 1000.0,
            optimal,
            execute,
            poses: heapless::Vec::new(),
        };
        for &s in &self.states {
            let (node, theta) = self.lat.decode(s);
            let Some(n) = trav.node(node) else { continue };
            let p = trav.position(n);
            let yaw = theta as f64 * bin;
            if msg
                .poses
                .push([p[0] as f32, p[1] as f32, p[2] as f32, yaw as f32])
                .is_err()
            {
                break;
            }
        }
        self.counters.plans_published += 1;
        if execute {
            if let Some(ex) = &mut self.explore {
                ex.driving(msg.query);
                bus.exploration.goal = Some(self.query.order[self.query.tried].1);
            }
        }
        bus.plan.publish(now, msg);
    }

    /// Milliseconds of mission time since the query began.
    fn since_query_ms(&self, now: u64) -> u32 {
        ((now.saturating_sub(self.query.began_ns)) / 1_000_000).min(u32::MAX as u64) as u32
    }

    fn search_step(&mut self, bus: &mut Bus, now: u64, units: u32) {
        let before = self.search.stats().expansions;
        let progress = self.search.step(&self.lat, units);
        let stats = self.search.stats();
        self.counters.expansions += stats.expansions - before;
        match progress {
            Progress::Searching => {
                let e = stats.expansions;
                let give_up = match (&self.explore, self.query.solved) {
                    (None, _) => e >= self.max_expansions,
                    (Some(_), false) => e >= EXPLORE_GOAL_EXPANSIONS.min(self.max_expansions),
                    (Some(_), true) => e >= self.query.solved_at + EXPLORE_IMPROVE_EXPANSIONS,
                };
                if give_up {
                    if self.query.solved {
                        self.counters.abandoned += 1;
                        if self.explore.is_some() {
                            // The best plan so far is the one to drive.
                            let best = (self.query.cost, self.query.eps_milli);
                            self.plan_found(bus, now, best, false);
                        } else {
                            self.end_query();
                        }
                    } else {
                        self.goal_failed("expansion limit");
                    }
                }
            }
            Progress::Solution { eps_milli, cost } => {
                self.solution(now);
                self.query.eps_milli = eps_milli;
                self.query.cost = cost;
                if self.query.solved_at == 0 {
                    self.query.solved_at = stats.expansions;
                }
                self.publish(bus, now, (cost, eps_milli), false, false);
            }
            Progress::Optimal { cost } => {
                self.solution(now);
                self.query.eps_milli = 1000;
                self.counters.optimal += 1;
                let ms = self.since_query_ms(now);
                if self.optimal_ms.len() < HISTORY {
                    self.optimal_ms.push(ms);
                }
                if self.explore.is_some() {
                    self.plan_found(bus, now, (cost, 1000), true);
                } else {
                    self.publish(bus, now, (cost, 1000), true, false);
                    self.end_query();
                }
            }
            Progress::NoPath | Progress::Idle => self.goal_failed("search exhausted"),
        }
    }

    /// Exploring, the query's plan is final: drive it, or first drive it in
    /// the internal simulator.
    fn plan_found(&mut self, bus: &mut Bus, now: u64, best: (u32, u32), optimal: bool) {
        let validate = self.explore.as_ref().is_some_and(|e| e.validates());
        // Shown while it is validated; marked to be driven otherwise.
        self.publish(bus, now, best, optimal, !validate);
        if self.explore.is_none() {
            return;
        }
        self.query.best = (best, optimal);
        if !self.simulate_shown_plan(bus, now) {
            self.end_query();
        }
    }

    /// The retrace just shown is driven in the internal simulator first,
    /// as every plan is: a blind one turned the garage's rover round at
    /// the roof's ramp opening until it hung tilted over the edge.
    fn validate_retrace(&mut self, bus: &Bus, now: u64, pose: &speleo_messages::SlamPose) -> bool {
        self.query = Query {
            began_ns: now,
            rover: pose.position,
            yaw: yaw_of(pose.orientation),
            attitude: pose.orientation,
            retrace: true,
            ..Query::default()
        };
        self.simulate_shown_plan(bus, now)
    }

    /// Begin driving the plan shown on the bus in the internal simulator
    /// from the query's pose (the `Validate` phase); false without a
    /// simulator or a plan.
    fn simulate_shown_plan(&mut self, bus: &Bus, now: u64) -> bool {
        let Some(ex) = self.explore.as_deref_mut() else {
            return false;
        };
        // Exploring plans only: a retrace goes back the way the rover
        // came, and home is where it must go anyway.
        let way_back = !self.query.retrace && ex.mode() == Mode::Exploring;
        let (Some(sim), Some(plan)) = (ex.sim_home(), bus.plan.get()) else {
            return false;
        };
        let start = Stance::from_quat(self.query.rover, self.query.attitude);
        let poses = plan
            .value
            .poses
            .iter()
            .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64, p[3] as f64]);
        sim.begin(start, poses.clone());
        if way_back {
            sim.check_way_back();
        }
        if let Some(d) = &ex.dump {
            d.begin(now, start, way_back, poses);
        }
        ex.validation_began_ns = now;
        // The old world's teardown needs no clouds: on the worker already.
        ex.sim_lend();
        self.phase = Phase::Validate;
        true
    }

    /// A slice of the internal simulation; at its verdict, the plan is
    /// driven or the next goal is tried. With a worker, the batch it did
    /// since the last frame is taken back, the clouds' integration done
    /// here, and the rest lent to it again.
    fn validate(&mut self, bus: &mut Bus, now: u64, units: usize) {
        let Some(ex) = self.explore.as_deref_mut() else {
            self.end_query();
            return;
        };
        let offloaded = ex.worker.is_some();
        let mount = ex.mount;
        // Out of `ex` while the simulator is borrowed from it.
        let mut dump = ex.dump.take();
        let Some(sim) = ex.sim_home() else {
            ex.dump = dump;
            self.end_query();
            return;
        };
        let verdict = if !offloaded || sim.needs_clouds() {
            let clouds = crate::sim_clouds::MapClouds {
                clouds: &bus.keyframe_clouds,
                mount: &mount,
            };
            match &dump {
                Some(d) => {
                    let keep = sim.read_region();
                    let rec = speleo_simulator::RecordingClouds {
                        inner: &clouds,
                        case: &d.case,
                        keep,
                    };
                    sim.step(&rec, units)
                }
                None => sim.step(&clouds, units),
            }
        } else {
            sim.verdict()
        };
        let Some(v) = verdict else {
            ex.dump = dump;
            ex.sim_lend();
            return;
        };
        // Where the simulated rover ended (a tip-over before the first
        // sample leaves the prediction empty).
        let end = sim
            .rover_state()
            .map(|b| b.position)
            .or_else(|| sim.prediction().last().copied())
            .unwrap_or([f64::NAN; 3]);
        ex.record_verdict(v.outcome, now);
        if let Some(d) = &mut dump {
            d.finish(ex.counters.validations, v);
        }
        ex.dump = dump;
        tracing::debug!(outcome = ?v.outcome, drive_s = v.drive_s, goal_error_m = v.goal_error_m, start_z = self.query.rover[2], end_x = end[0], end_y = end[1], end_z = end[2], retrace = self.query.retrace, "simulated");
        if self.query.retrace && ex.backing_out() {
            let query = self.counters.queries;
            if Exploration::back_out_passes(v.outcome) {
                drive_shown_plan(bus, now);
                ex.back_out_passed(query);
            } else {
                tracing::debug!(outcome = ?v.outcome, "back-out refused");
                ex.back_out_refused();
            }
            self.end_query();
            return;
        }
        if self.query.retrace {
            let query = self.counters.queries;
            if v.success() {
                drive_shown_plan(bus, now);
                ex.driving(query);
                ex.compare_next(query);
            } else {
                ex.retrace_refused();
            }
            self.end_query();
            return;
        }
        if v.success() {
            let (best, optimal) = self.query.best;
            self.publish(bus, now, best, optimal, true);
            if let Some(ex) = self.explore.as_deref_mut() {
                ex.compare_next(ex.executing);
            }
            self.end_query();
            return;
        }
        let at = self.query.order[self.query.tried].1;
        if ex.mode() == Mode::Exploring {
            ex.explorer.reject([at[0], at[1]]);
            // A tip-over's or a fall's run-up is no ground to stop on; a
            // plan without a way back was driven whole.
            if !matches!(
                v.outcome,
                Outcome::TippedOver | Outcome::Fell | Outcome::NoWayBack
            ) {
                if let Some(plan) = bus.plan.get() {
                    ex.offer_partial(&plan.value.poses, at);
                }
            }
        }
        self.phase = self.try_goal(self.query.tried + 1);
    }

    /// A plan exists: the first one's latency is kept.
    fn solution(&mut self, now: u64) {
        if !self.query.solved {
            self.query.solved = true;
            self.counters.solved += 1;
            let ms = self.since_query_ms(now);
            if self.first_ms.len() < HISTORY {
                self.first_ms.push(ms);
            }
        }
    }
}

impl Task<Bus> for PlannerTask {
    fn run(&mut self, _bus: &mut Bus, _cx: &Context) {}

    /// One phase's work for its units (`planner.step_units`, at most the
    /// scheduler's quantum): graph nodes grown, nodes scanned, lattice
    /// preparation units, expansions or internal simulator units.
    fn step(&mut self, bus: &mut Bus, cx: &Context, quantum: u32) -> StepResult {
        if let Some(ex) = &mut self.explore {
            ex.observe(bus, cx.time_ns);
        }
        let timed = self.phase.timed_index();
        let units = match timed {
            Some(i) => {
                let u = self.step_units[i].min(quantum).max(1);
                self.step_units_run[i] = u;
                u
            }
            None => quantum.max(1),
        };
        // The lattice's own stage (map copy, room, cost-to-go) when a step
        // begins, for the slow-step log.
        let lattice = self.lat.phase();
        let started = std::time::Instant::now();
        let cpu0 = thread_cpu_ns();
        let went_on = self.work(bus, cx, units);
        if let Some(i) = timed {
            let wall_ns = started.elapsed().as_nanos() as u64;
            let cpu_ns = thread_cpu_ns().saturating_sub(cpu0);
            self.step_times[i].record(wall_ns);
            self.step_cpu_times[i].record(cpu_ns);
            if cpu_ns > SLOW_STEP_NS {
                // Which phase, and whether the step ended it: what a
                // calibration by units cannot see.
                tracing::debug!(phase = PHASE_NAMES[i], lattice, units, cpu_us = cpu_ns / 1000, wall_us = wall_ns / 1000, next = ?self.phase.timed_index().map(|j| PHASE_NAMES[j]), "slow planner step");
            }
        }
        if !went_on || self.phase == Phase::Idle {
            StepResult::Idle
        } else {
            StepResult::Continue
        }
    }
}

impl PlannerTask {
    /// One step of the phase under way; false when the query could not
    /// begin or go on.
    fn work(&mut self, bus: &mut Bus, cx: &Context, units: u32) -> bool {
        match self.phase {
            Phase::Idle => {
                if !self.begin_query(bus, cx.time_ns) {
                    return false;
                }
            }
            Phase::Grow { candidate } => {
                let mls = bus.surface.serving();
                if self.lat.trav_mut().grow(mls, units as u64 * GROW_PER_UNIT) {
                    if let Some(ex) = &self.explore {
                        // Where the rover was stuck, no path goes (but the
                        // rover may start from where it stands).
                        let keep = [self.query.rover[0], self.query.rover[1]];
                        for p in ex.no_go.iter() {
                            self.lat
                                .trav_mut()
                                .forbid(*p, NO_GO_RADIUS_M, keep, NO_GO_SPARE_M);
                        }
                        // Nor near a rim the rover was stopped at.
                        for p in ex.rims.iter() {
                            self.lat
                                .trav_mut()
                                .forbid(*p, RIM_RADIUS_M, keep, NO_GO_SPARE_M);
                        }
                        // Exploring, not up a slope the rover slid on (the
                        // way home may have to go up one).
                        if ex.explorer.mode() == Mode::Exploring {
                            for p in ex.slides.iter() {
                                self.lat
                                    .trav_mut()
                                    .forbid_above(*p, SLIDE_RADIUS_M, SLIDE_RISE_M);
                            }
                        }
                    }
                    let trav = self.lat.trav();
                    let s = trav.stats();
                    tracing::debug!(
                        nodes = s.nodes,
                        work = trav.work_done(),
                        full = s.full,
                        "graph grown"
                    );
                    self.counters.nodes_max = self.counters.nodes_max.max(s.nodes as u64);
                    if s.full {
                        self.counters.graphs_full += 1;
                    }
                    let start_drivable = trav.node(0).is_some_and(|n| n.class.is_drivable());
                    if start_drivable {
                        self.phase = Phase::Pick { next: 0 };
                    } else if !self.begin_growth(mls, candidate + 1) {
                        return false;
                    }
                }
            }
            Phase::Pick { next } => {
                self.phase = self.pick(next, units as usize);
            }
            Phase::Candidates => {
                let (rover, failed) = (self.query.rover, self.counters.no_goal);
                self.phase = self.candidates(units as usize);
                if self.counters.no_goal != failed {
                    trace_cells_near(bus.surface.serving(), rover, GRAPH_TRACE_RADIUS_M);
                }
            }
            Phase::Prepare => {
                if self.lat.prepare(bus.surface.serving(), units as usize) {
                    let (start, _) = self.lat.decode(self.query.start_state);
                    if tracing::enabled!(tracing::Level::TRACE) {
                        tracing::trace!(
                            nodes = self.lat.trav().nodes().len(),
                            over_rocks = self.lat.rocky_nodes(),
                            "lattice prepared"
                        );
                    }
                    if self.goal_on_a_rock() {
                        return true;
                    }
                    if !self.lat.reaches(start) {
                        // No corridor wide enough leads there: not worth
                        // a search to its expansion limit.
                        self.goal_failed("no corridor");
                        return true;
                    }
                    self.search.start(
                        &self.lat,
                        self.query.start_state,
                        self.lat.goal_state(),
                        self.params,
                    );
                    self.phase = Phase::Search;
                }
            }
            Phase::Search => self.search_step(bus, cx.time_ns, units),
            Phase::Validate => self.validate(bus, cx.time_ns, units as usize),
            Phase::Partial => self.drive_partial(bus, cx.time_ns),
        }
        true
    }
}

/// The plan shown on the bus (a retrace or a back-out the simulation
/// passed), marked to be driven.
fn drive_shown_plan(bus: &mut Bus, now: u64) {
    if let Some(p) = bus.plan.get() {
        let mut msg = p.value.clone();
        msg.execute = true;
        bus.plan.publish(now, msg);
    }
}

/// Horizontal ground patches near the rover, about `base_height_m` under
/// base_link, nearest first: where the graph may grow from.
fn start_candidates(
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
fn goal_distance2(p: [f64; 3], g: [f64; 2], z: Option<f64>) -> Option<f64> {
    let d2 = (p[0] - g[0]).powi(2) + (p[1] - g[1]).powi(2);
    let level = z.is_none_or(|z| (p[2] - z).abs() <= LEVEL_M);
    (d2 <= GOAL_REACH_M * GOAL_REACH_M && level).then_some(d2)
}

/// The point `ahead` metres along the route from the rover's projection
/// on segment `segment`, and the route's heading there.
fn point_ahead(
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

/// The graph's nodes this near the rover are traced where no candidate
/// was found, m.
const GRAPH_TRACE_RADIUS_M: f64 = 8.0;

/// Every node within `radius_m` of `rover` as a trace line (target
/// `speleo::graph`): where the graph ends and why, to look at after a
/// mission (`RUST_LOG=debug,speleo::graph=trace`). Nothing is done
/// unless that target traces.
fn trace_graph_near(trav: &speleo_traversability::TravMap, rover: [f64; 3], radius_m: f64) {
    if !tracing::enabled!(target: "speleo::graph", tracing::Level::TRACE) {
        return;
    }
    for n in trav.nodes() {
        let [x, y, z] = trav.position(n);
        if (x - rover[0]).hypot(y - rover[1]) > radius_m {
            continue;
        }
        tracing::trace!(
            target: "speleo::graph",
            x,
            y,
            z,
            patch_z = n.patch_z,
            slope_deg = n.slope_deg,
            class = ?n.class,
            blocked = ?n.blocked,
            cut = n.cut,
            "node"
        );
    }
}

/// Every MLS patch within `radius_m` of `rover` as a trace line (target
/// `speleo::cells`), beside the graph's nodes where no candidate was
/// found: what the map holds where the graph ends (on the garage's roof
/// ramp, a slab's top and underside both seen from below, or only its
/// underside). Nothing is done unless that target traces.
fn trace_cells_near(mls: &MlsMap, rover: [f64; 3], radius_m: f64) {
    if !tracing::enabled!(target: "speleo::cells", tracing::Level::TRACE) {
        return;
    }
    let (lo, hi) = (
        [rover[0] - radius_m, rover[1] - radius_m],
        [rover[0] + radius_m, rover[1] + radius_m],
    );
    mls.for_each_in_region(lo, hi, |ix, iy, patches| {
        let [x, y] = mls.cell_center(ix, iy);
        if (x - rover[0]).hypot(y - rover[1]) > radius_m {
            return;
        }
        for p in patches {
            tracing::trace!(
                target: "speleo::cells",
                x,
                y,
                mean = p.mean,
                min = p.min,
                max = p.max,
                top = p.top,
                under = (p.under > f32::MIN).then_some(p.under),
                count = p.count,
                top_count = p.top_count,
                kind = ?p.kind,
                seen_from_above = p.seen_from_above,
                top_seen_from_above = p.top_seen_from_above,
                under_seen_from_above = p.under_seen_from_above,
                ground = p.ground(),
                "patch"
            );
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface_maps::SurfaceMaps;
    use speleo_mapping::mls::MlsParams;
    use speleo_messages::SlamPose;

    use crate::tasks::exploration::ExplorationCounters;
    use crate::tasks::sim_worker::SimWorker;
    use crate::tasks::test_context as cx;

    /// A 12 x 4 m floor seen densely, 0.17 m under base_link at (1, 2),
    /// with a boulder in the middle of the way.
    fn bus_on_a_floor() -> Box<Bus> {
        let mut pts = Vec::new();
        for i in 0..240 {
            for j in 0..80 {
                let (x, y) = (i as f64 * 0.05 + 0.025, j as f64 * 0.05 + 0.025);
                let rock = (x - 6.0).powi(2) + (y - 2.0).powi(2) < 0.36;
                pts.push([x, y, if rock { 0.5 } else { 0.0 }]);
            }
        }
        bus_with_map(&pts, [1.0, 2.0, 0.17])
    }

    /// A bus whose serving map holds `pts`, with the rover's SLAM pose at
    /// `at`, level and heading along x.
    fn bus_with_map(pts: &[[f64; 3]], at: [f64; 3]) -> Box<Bus> {
        let mut bus = Bus::new();
        bus.surface = SurfaceMaps::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
        let m = bus.surface.active();
        bus.surface.map_mut(m).insert_points(pts);
        bus.slam.publish(
            0,
            SlamPose {
                position: at,
                orientation: [1.0, 0.0, 0.0, 0.0],
                keyframes: 1,
            },
        );
        bus
    }

    fn task(route: &[[f64; 2]]) -> PlannerTask {
        let cfg = PlannerConfig::default();
        let prims = speleo_planner::primitives::generate(&Default::default());
        PlannerTask::new(&cfg, &prims, 0.1, route, false, 0.17).unwrap_or_else(|e| panic!("{e}"))
    }

    /// The plan on the bus.
    fn published(bus: &Bus) -> PlanMsg {
        bus.plan
            .get()
            .unwrap_or_else(|| panic!("no plan published"))
            .value
            .clone()
    }

    /// Steps until the first query ends; the frames it took.
    fn run_query(t: &mut PlannerTask, bus: &mut Bus) -> u64 {
        for f in 0..20_000 {
            let r = t.step(bus, &cx(f), 32);
            if r == StepResult::Idle && f > 0 {
                return f;
            }
        }
        panic!("the query never ended: {:?}", t.counters);
    }

    #[test]
    fn a_query_plans_around_the_boulder_to_the_route_ahead_the_same_every_time() {
        let route = [[1.0, 2.0], [11.0, 2.0]];
        let mut bus = bus_on_a_floor();
        let mut t = task(&route);
        let frames = run_query(&mut t, &mut bus);
        let c = t.counters;
        assert_eq!((c.queries, c.solved, c.optimal), (1, 1, 1), "{c:?}");
        let plan = published(&bus);
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
        let mut again_bus = bus_on_a_floor();
        let mut again = task(&route);
        assert_eq!(run_query(&mut again, &mut again_bus), frames);
        assert_eq!(again.counters, t.counters);
        assert_eq!(again_bus.plan.get().map(|p| p.value.clone()), Some(plan));
        assert_eq!(again.first_ms, t.first_ms);
    }

    #[test]
    fn a_route_beyond_the_map_gives_no_goal_and_nothing_is_published() {
        let mut bus = bus_on_a_floor();
        let mut t = task(&[[1.0, 2.0], [-30.0, 2.0]]);
        run_query(&mut t, &mut bus);
        assert_eq!(
            (t.counters.queries, t.counters.no_goal),
            (1, 1),
            "{:?}",
            t.counters
        );
        assert!(bus.plan.get().is_none());
    }

    fn exploring_task() -> PlannerTask {
        let e = crate::config::ExplorationConfig::default();
        task(&[]).with_exploration(Exploration::new(
            e.explorer_params(),
            e.candidate_params(),
            None,
            0.0,
        ))
    }

    #[test]
    fn exploring_plans_to_the_border_of_the_map_and_marks_the_plan_to_be_driven() {
        let mut bus = bus_on_a_floor();
        let mut t = exploring_task();
        run_query(&mut t, &mut bus);
        let plan = published(&bus);
        assert!(plan.execute && plan.optimal, "{plan:?}");
        let last = plan.poses[plan.poses.len() - 1];
        // A border of the seen floor (nothing was seen beyond it) outside
        // the 3 m the rover has covered around (1, 2).
        let ex = t.exploration().unwrap_or_else(|| panic!("exploring"));
        assert_eq!(ex.counters.plans_executed, 1);
        assert_eq!(ex.executing, plan.query);
        let g = bus.exploration.goal.unwrap_or_else(|| panic!("no goal"));
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
            t.step(&mut bus, &cx(20_000 + f), 32);
        }
        assert_eq!(t.counters.queries, 1);
    }

    #[test]
    fn a_query_that_drives_nothing_widens_the_next_window_up_to_its_most_a_plan_driven_restores_it()
    {
        // A 2 x 2 m floor all within the 3 m the rover covers where it
        // stands: nothing to explore from here.
        let mut pts = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                pts.push([i as f64 * 0.05, j as f64 * 0.05, 0.0]);
            }
        }
        let mut bus = bus_with_map(&pts, [1.0, 1.0, 0.17]);
        let mut t = exploring_task();
        let cfg = PlannerConfig::default();
        assert_eq!(t.window_half_m, cfg.window_m / 2.0);
        run_query(&mut t, &mut bus);
        assert_eq!(t.counters.queries, 1);
        assert_eq!(t.window_half_m, cfg.window_m * 1.5 / 2.0);
        // Never past the most.
        t.window_half_m = cfg.window_max_m / 2.0 - 1.0;
        t.end_query();
        assert_eq!(t.window_half_m, cfg.window_max_m / 2.0);
        assert!(bus.plan.get().is_none());
        // On a floor with somewhere to go, the plan driven brings the
        // window back.
        let mut bus = bus_on_a_floor();
        let mut t = exploring_task();
        t.window_half_m = cfg.window_max_m / 2.0;
        run_query(&mut t, &mut bus);
        assert!(published(&bus).execute);
        assert_eq!(t.window_half_m, cfg.window_m / 2.0);
    }

    /// Height of the ledge: over the planner's configured step, but the
    /// rover (0.19 m wheels) climbs no more than about 0.2 m.
    const LEDGE_M: f64 = 0.3;

    /// A 16 x 4 m corridor with a ledge across it at x = 10, seen densely
    /// from three keyframes along it; the rover at (`rover_x`, 2). Closed,
    /// a wall shuts the corridor's near end.
    fn bus_before_a_ledge(rover_x: f64, closed: bool) -> Box<Bus> {
        let ground = |x: f64, _| if x < 10.0 { 0.0 } else { LEDGE_M };
        let sensors = [[4.0, 2.0, 0.8], [8.0, 2.0, 0.8], [12.0, 2.0, 1.1]];
        bus_in_a_corridor(ground, closed, [rover_x, 2.0, 0.17], &sensors)
    }

    /// A 16 x 4 m corridor along x of floor `ground(x, y)`, a face
    /// wherever it steps along x, seen densely from `sensors`; the rover at
    /// `rover`. Closed, a wall shuts the corridor's near end.
    fn bus_in_a_corridor(
        ground: impl Fn(f64, f64) -> f64,
        closed: bool,
        rover: [f64; 3],
        sensors: &[[f64; 3]],
    ) -> Box<Bus> {
        use crate::keyframe_clouds::KeyframeClouds;
        use nalgebra::{Matrix3, Vector3};
        use speleo_slam::lie::Pose;
        let mut pts = Vec::new();
        for i in 0..320 {
            for j in 0..80 {
                let (x, y) = (i as f64 * 0.05 + 0.025, j as f64 * 0.05 + 0.025);
                let z = ground(x, y);
                pts.push([x, y, z]);
                // Walls along both sides: a corridor open at its ends.
                if j == 0 || j == 79 {
                    for k in 1..20 {
                        pts.push([x, y, z + 0.05 * k as f64]);
                    }
                }
                if closed && i == 0 {
                    for k in 1..20 {
                        pts.push([0.0, y, 0.05 * k as f64]);
                    }
                }
                // The face between this column and the next.
                let next = ground(x + 0.05, y);
                let mut h = z.min(next) + 0.05;
                while h < z.max(next) {
                    pts.push([x + 0.025, y, h]);
                    h += 0.05;
                }
            }
        }
        let mut bus = bus_with_map(&pts, rover);
        bus.keyframe_clouds = KeyframeClouds::new(sensors.len(), pts.len());
        for o in sensors {
            assert!(bus.keyframe_clouds.begin());
            for p in &pts {
                bus.keyframe_clouds
                    .push([p[0] - o[0], p[1] - o[1], p[2] - o[2]]);
            }
            bus.keyframe_clouds.commit();
        }
        bus.keyframe_clouds.set_poses(
            sensors
                .iter()
                .map(|&o| Pose::new(Matrix3::identity(), Vector3::from(o))),
        );
        bus
    }

    /// Exploration before the ledge, plans validated in the simulator (on
    /// a worker core when `worker_units` > 0) until one is marked to be
    /// driven: the counters, the plan and the frame it came at.
    /// The counters, the plan driven, and the frame it came at with the
    /// frames spent validating.
    fn ledge_mission(worker_units: u32) -> (ExplorationCounters, PlanMsg, (u64, u64)) {
        ledge_mission_from(worker_units, bus_before_a_ledge(8.0, false))
    }

    fn ledge_mission_from(
        worker_units: u32,
        mut bus: Box<Bus>,
    ) -> (ExplorationCounters, PlanMsg, (u64, u64)) {
        // A planner told the rover steps up to 0.35 m, drawn toward the
        // far side of the ledge, and not wary of bumps (the ledge's edge).
        let cfg = PlannerConfig {
            max_step_m: 0.35,
            ground_clearance_m: 0.4,
            bump_weight: 0.0,
            ..PlannerConfig::default()
        };
        let prims = speleo_planner::primitives::generate(&Default::default());
        let e = crate::config::ExplorationConfig {
            weight_target: 1.0,
            ..Default::default()
        };
        let sim = speleo_simulator::InternalSim::new(Default::default())
            .unwrap_or_else(|e| panic!("{e}"));
        let mut ex = Exploration::new(
            e.explorer_params(),
            e.candidate_params(),
            Some([40.0, 2.0]),
            0.0,
        )
        .with_simulator(sim, speleo_slam::lie::Pose::identity());
        let mut sync = None;
        if worker_units > 0 {
            let w = SimWorker::spawn(worker_units, 0.01, 0).unwrap_or_else(|e| panic!("{e}"));
            sync = Some(w.sync());
            ex = ex.with_worker(w);
        }
        let mut t = PlannerTask::new(&cfg, &prims, 0.1, &[], false, 0.17)
            .unwrap_or_else(|e| panic!("{e}"))
            .with_exploration(ex);
        let (mut frame, mut validating) = (0, 0);
        for f in 0..400_000 {
            if let Some(s) = &sync {
                s.wait_idle();
            }
            validating += matches!(t.phase, Phase::Validate) as u64;
            t.step(&mut bus, &cx(f), 32);
            frame = f;
            if bus.plan.get().is_some_and(|p| p.value.execute) {
                break;
            }
        }
        let ex = t.exploration().unwrap_or_else(|| panic!("exploring"));
        (ex.counters, published(&bus), (frame, validating))
    }

    /// A rover standing at x = 8 m before the ledge, its track coming
    /// from `from_x`, stranded (no plan): the planner's steps until a
    /// retrace is marked to be driven or `frames` pass; the counters and
    /// the plans shown, in order.
    fn retrace_before_a_ledge(from_x: f64, frames: u64) -> (ExplorationCounters, Vec<PlanMsg>) {
        let (c, shown, _) = retraces_before_a_ledge(from_x, frames);
        (c, shown)
    }

    /// Exploration with the default settings, every plan validated in
    /// a default internal simulator.
    fn validating_exploration() -> Exploration {
        let e = crate::config::ExplorationConfig::default();
        let sim = speleo_simulator::InternalSim::new(Default::default())
            .unwrap_or_else(|e| panic!("{e}"));
        Exploration::new(e.explorer_params(), e.candidate_params(), None, 0.0)
            .with_simulator(sim, speleo_slam::lie::Pose::identity())
    }

    /// [`retrace_before_a_ledge`], and the explorer's mode at the end.
    fn retraces_before_a_ledge(
        from_x: f64,
        frames: u64,
    ) -> (ExplorationCounters, Vec<PlanMsg>, Mode) {
        let mut bus = bus_before_a_ledge(8.0, false);
        let cfg = PlannerConfig::default();
        let prims = speleo_planner::primitives::generate(&Default::default());
        let mut ex = validating_exploration();
        let ground = |x: f64| if x < 10.0 { 0.17 } else { 0.17 + LEDGE_M };
        let steps = ((from_x - 8.0).abs() / 0.1) as u64;
        for k in 0..=steps {
            let x = from_x + (8.0 - from_x) * k as f64 / steps as f64;
            bus.slam.publish(
                k * 100_000_000,
                SlamPose {
                    position: [x, 2.0, ground(x)],
                    orientation: [1.0, 0.0, 0.0, 0.0],
                    keyframes: 1,
                },
            );
            ex.observe(&mut bus, k * 100_000_000);
        }
        ex.no_start();
        let mut t = PlannerTask::new(&cfg, &prims, 0.1, &[], false, 0.17)
            .unwrap_or_else(|e| panic!("{e}"))
            .with_exploration(ex);
        let mut shown: Vec<PlanMsg> = Vec::new();
        for f in 0..frames {
            t.step(&mut bus, &cx(steps + 1 + f), 32);
            if let Some(p) = bus.plan.get() {
                if shown.last() != Some(&p.value) {
                    shown.push(p.value.clone());
                }
                if p.value.execute {
                    break;
                }
            }
            if t.exploration().is_some_and(|e| e.mode() == Mode::Stranded) {
                break;
            }
        }
        let ex = t.exploration().unwrap_or_else(|| panic!("exploring"));
        (ex.counters, shown, ex.mode())
    }

    #[test]
    fn retraces_refused_again_and_again_at_one_place_end_in_going_home_not_a_loop() {
        // Only back up the ledge leads anywhere: four refusals, then home
        // by plans (none, the ledge is the only way), four more, stranded.
        let (c, shown, mode) = retraces_before_a_ledge(13.0, 200_000);
        assert!(shown.iter().all(|p| !p.execute), "{shown:?}");
        assert_eq!(mode, Mode::Stranded, "{c:?}");
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
        let mut bus = bus_in_a_corridor(ground, false, [9.7, 2.0, 0.17], &sensors);
        let cfg = PlannerConfig::default();
        let prims = speleo_planner::primitives::generate(&Default::default());
        let mut ex = validating_exploration();
        ex.observe(&mut bus, 0);
        bus.command.publish(
            100_000_000,
            WheelCommand {
                done: true,
                stop: Some(StopReason::Stuck),
                ..Default::default()
            },
        );
        let mut t = PlannerTask::new(&cfg, &prims, 0.1, &[], false, 0.17)
            .unwrap_or_else(|e| panic!("{e}"))
            .with_exploration(ex);
        let mut shown: Vec<PlanMsg> = Vec::new();
        for f in 0..200_000 {
            t.step(&mut bus, &cx(2 + f), 32);
            if let Some(p) = bus.plan.get() {
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

    #[test]
    fn a_goal_beyond_a_ledge_the_rover_cannot_climb_is_refused_by_the_simulation_and_another_chosen(
    ) {
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
        let (c, plan, _) = ledge_mission_from(0, bus_before_a_ledge(3.0, true));
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
        let mut bus = bus_in_a_corridor(ground, true, [3.0, 2.0, 0.17], &sensors);
        let (goal_rule, limit) = if planner_limit {
            (0.0, 0.06)
        } else {
            (0.06, 0.0)
        };
        let cfg = PlannerConfig {
            max_bump_m: limit,
            ..PlannerConfig::default()
        };
        let prims = speleo_planner::primitives::generate(&Default::default());
        let e = crate::config::ExplorationConfig {
            weight_target: 1.0,
            max_goal_rock_m: goal_rule,
            ..Default::default()
        };
        let ex = Exploration::new(
            e.explorer_params(),
            e.candidate_params(),
            Some([40.0, 2.0]),
            0.0,
        );
        let mut t = PlannerTask::new(&cfg, &prims, 0.1, &[], false, 0.17)
            .unwrap_or_else(|e| panic!("{e}"))
            .with_exploration(ex);
        for f in 0..100_000 {
            t.step(&mut bus, &cx(f), 32);
            if bus.plan.get().is_some_and(|p| p.value.execute) {
                break;
            }
        }
        let ex = t.exploration().unwrap_or_else(|| panic!("exploring"));
        (ex.counters, published(&bus))
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

    /// The far end of the floor as the target, and perhaps a place the
    /// rover was stuck at on the straight way there: the plan.
    fn plan_toward_the_far_end(no_go: Option<[f64; 3]>) -> PlanMsg {
        plan_toward_the_far_end_barred(no_go, None)
    }

    /// As [`plan_toward_the_far_end`], with a rim kept too.
    fn plan_toward_the_far_end_barred(no_go: Option<[f64; 3]>, rim: Option<[f64; 3]>) -> PlanMsg {
        let e = crate::config::ExplorationConfig {
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
        let mut bus = bus_on_a_floor();
        run_query(&mut t, &mut bus);
        published(&bus)
    }

    fn nearest_m(plan: &PlanMsg, at: [f64; 2]) -> f64 {
        plan.poses
            .iter()
            .map(|p| (p[0] as f64 - at[0]).hypot(p[1] as f64 - at[1]))
            .fold(f64::INFINITY, f64::min)
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
    fn driven_from_x1_to_x5() -> (Exploration, Box<Bus>) {
        let e = crate::config::ExplorationConfig::default();
        let mut ex = Exploration::new(e.explorer_params(), e.candidate_params(), None, 0.0);
        let mut bus = bus_on_a_floor();
        for k in 0..=40 {
            let x = 1.0 + 0.1 * k as f64;
            bus.slam.publish(
                k * 100_000_000,
                SlamPose {
                    position: [x, 2.0, 0.17],
                    orientation: [1.0, 0.0, 0.0, 0.0],
                    keyframes: 1,
                },
            );
            ex.observe(&mut bus, k * 100_000_000);
        }
        (ex, bus)
    }

    #[test]
    fn a_stuck_rover_backs_out_a_metre_straight_then_plans_then_backs_out_forward_and_remembers_the_place(
    ) {
        use speleo_control::StopReason;
        use speleo_messages::WheelCommand;
        let (mut ex, mut bus) = driven_from_x1_to_x5();
        // Then stuck.
        bus.command.publish(
            4_100_000_000,
            WheelCommand {
                done: true,
                stop: Some(StopReason::Stuck),
                ..Default::default()
            },
        );
        assert!(ex.ready(&bus, 4_100_000_000));
        assert_eq!(ex.no_go.len(), 1);
        let stuck_at = ex.no_go.front().copied().unwrap_or_default();
        assert!((stuck_at[0] - 5.0).abs() < 1e-9, "{stuck_at:?}");
        assert!(ex.retrace_due());
        ex.retrace(&mut bus, 4_200_000_000, 9, 8.0);
        let plan = published(&bus);
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
        bus.command.publish(
            4_300_000_000,
            WheelCommand {
                done: true,
                plan: 9,
                stop: Some(StopReason::Stuck),
                ..Default::default()
            },
        );
        assert!(ex.ready(&bus, 4_300_000_000));
        assert_eq!(ex.no_go.len(), 1);
        // The planner is asked first; only when it finds nothing from here
        // does the rover back out again.
        assert!(!ex.retrace_due());
        ex.query_over();
        assert!(ex.retrace_due());
        // Waiting for the next query does not act on the back-out's end
        // again (that undid the query's verdict for 4,000 queries).
        assert!(ex.ready(&bus, 4_350_000_000));
        assert!(ex.retrace_due());
        ex.retrace(&mut bus, 4_400_000_000, 10, 8.0);
        let last = *published(&bus)
            .poses
            .last()
            .unwrap_or_else(|| panic!("no poses"));
        assert!((last[0] - 6.0).abs() < 1e-3, "{last:?}");
    }

    #[test]
    fn a_rover_stuck_after_a_back_out_each_way_retraces_its_track_steered_then_backs_out_again() {
        use speleo_control::StopReason;
        use speleo_messages::WheelCommand;
        let (mut ex, mut bus) = driven_from_x1_to_x5();
        let straight = |p: &PlanMsg| p.poses.iter().all(|q| q[3].abs() < 1e-6);
        let mut t = 4_100_000_000;
        let mut escapes = Vec::new();
        for query in 9..15 {
            // Stuck where it stands, and the planner finds nothing.
            bus.command.publish(
                t,
                WheelCommand {
                    done: true,
                    plan: query - 1,
                    stop: Some(StopReason::Stuck),
                    ..Default::default()
                },
            );
            assert!(ex.ready(&bus, t));
            ex.query_over();
            assert!(ex.retrace_due());
            ex.retrace(&mut bus, t + 50_000_000, query, 3.0);
            let plan = published(&bus);
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
        let (mut ex, mut bus) = driven_from_x1_to_x5();
        ex.no_start();
        assert!(ex.retrace_due());
        ex.retrace(&mut bus, 4_200_000_000, 9, 3.0);
        let plan = published(&bus);
        let last = plan.poses[plan.poses.len() - 1];
        assert!((last[0] - 2.0).abs() < 0.6, "{plan:?}");
        // Facing back along the track (-x) all the way: driven forward.
        let back = |p: &[f32; 4]| (p[3].abs() - core::f32::consts::PI).abs() < 1e-3;
        assert!(plan.poses.iter().all(back), "{plan:?}");
        // It got nowhere (stopped where it began): backward this time,
        // facing +x as the rover does...
        ex.no_start();
        ex.retrace(&mut bus, 4_300_000_000, 10, 3.0);
        let plan = published(&bus);
        assert!(plan.poses.iter().all(|p| p[3].abs() < 1e-3), "{plan:?}");
        // ...and forward again after that.
        ex.no_start();
        ex.retrace(&mut bus, 4_400_000_000, 11, 3.0);
        assert!(published(&bus).poses.iter().all(back));
        assert_eq!(ex.counters.retraces, 3);
    }

    #[test]
    fn when_nothing_is_left_but_barred_places_they_are_forgotten_once_a_mission() {
        let e = crate::config::ExplorationConfig::default();
        let mut ex = Exploration::new(e.explorer_params(), e.candidate_params(), None, 0.0);
        assert!(!ex.second_look(), "nothing was barred");
        let _ = ex.no_go.push_back([1.0, 2.0, 0.0]);
        ex.explorer.reject([3.0, 4.0]);
        assert!(ex.second_look());
        assert!(ex.no_go.is_empty() && ex.explorer.rejected().is_empty());
        assert_eq!(ex.mode(), Mode::Exploring);
        assert_eq!(ex.counters.second_looks, 1);
        let _ = ex.no_go.push_back([1.0, 2.0, 0.0]);
        assert!(!ex.second_look(), "once a mission");
        assert_eq!(ex.no_go.len(), 1);
    }

    #[test]
    fn a_rover_that_made_no_progress_drops_its_goal_without_backing_out() {
        use speleo_control::StopReason;
        use speleo_messages::WheelCommand;
        let e = crate::config::ExplorationConfig::default();
        let mut ex = Exploration::new(e.explorer_params(), e.candidate_params(), None, 0.0);
        let mut bus = bus_on_a_floor();
        bus.slam.publish(
            0,
            SlamPose {
                position: [5.0, 2.0, 0.17],
                orientation: [1.0, 0.0, 0.0, 0.0],
                keyframes: 1,
            },
        );
        ex.observe(&mut bus, 0);
        // Circling a goal it could not settle on: the rover moves freely,
        // so the place is no obstacle, but the goal is not tried again.
        bus.exploration.goal = Some([5.5, 2.0, 0.0]);
        bus.command.publish(
            100_000_000,
            WheelCommand {
                done: true,
                stop: Some(StopReason::NoProgress),
                ..Default::default()
            },
        );
        assert!(ex.ready(&bus, 100_000_000));
        assert!(ex.no_go.is_empty());
        assert!(!ex.retrace_due());
        assert_eq!(ex.explorer.rejected(), &[[5.5, 2.0]]);
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
}
