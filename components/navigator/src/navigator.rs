//! The navigator: one query at a time, in fixed quanta of work. Every
//! `replan_every_s` (following a route) or when the last traverse is over
//! (exploring) it takes the SLAM pose, grows the traversability graph over
//! the serving MLS map within a window around the rover, picks the start
//! and the goals, prepares the lattice (cell index, body checks, the
//! cost-to-go) and runs ARA*, publishing the first plan as soon as it
//! exists and each better one as epsilon falls. Exploring, the goals are
//! the exploration's candidates (or points of the track home), each plan is
//! driven in the internal simulator before it is marked to be driven, and
//! the recovery behaviour (`exploration::recovery`) takes over when no plan
//! is found. Each step does one phase's work for its units, so the same
//! inputs give the same plans at the same frames on any machine.
//!
//! Every buffer (graph, lattice, search, plan) is taken at start-up for
//! `max_nodes` nodes and the window's cells: nothing is allocated while
//! planning.

use speleo_planner::arastar::{AraParams, AraStar, Lattice};
use speleo_planner::mprim::MprimFile;
use speleo_planner::surface::{SurfaceLattice, SurfaceParams, SOLID_PER_CELL};
use speleo_traversability::{TravMap, TravParams};

use speleo_exploration::ExplorerPhase;

use crate::exploration::{Exploration, NO_GO_RADIUS_M, RIM_RADIUS_M, SLIDE_RADIUS_M, SLIDE_RISE_M};
use crate::input::{NavInput, Outbox};
use crate::query::{Phase, Query};
use crate::rehearsal::Rehearsal;
use crate::trace::{trace_cells_near, GRAPH_TRACE_RADIUS_M};
use crate::NavigatorCounters;
use speleo_messages::{ExplorationStatus, PlanMsg};

mod validate;

/// The phases whose steps are timed, in [`Navigator::timed_phase`] order.
pub const STEP_PHASES: [&str; 6] = [
    "grow",
    "pick",
    "candidates",
    "prepare",
    "search",
    "validate",
];

/// Results kept for the report's medians (a query every few seconds: days
/// of mission).
pub(crate) const HISTORY: usize = 8192;
/// Start patches tried, nearest the rover first.
pub(crate) const START_CANDIDATES: usize = 8;
/// How far from the rover the start patch may be (the LiDAR does not see
/// the ground right under the rover until it has moved), m.
pub(crate) const START_REACH_M: f64 = 1.5;

/// Nodes this near the rover stay drivable inside a no-go place (the
/// query must start from somewhere), m.
pub(crate) const NO_GO_SPARE_M: f64 = 0.3;
/// How far from the point ahead on the route the goal node may be, m.
pub(crate) const GOAL_REACH_M: f64 = 1.0;
/// How far above or below the rover its start node, and a goal point that
/// has a height (a point of the track home) its goal node, may lie, m: on
/// the garage's way home, the track's point on level 1 took the node over
/// it on level 2, and the rover drove back up the ramp it had just come
/// down, again and again.
pub(crate) const LEVEL_M: f64 = 1.0;
/// Where the map does not reach `goal_ahead_m` yet, the goal comes back
/// along the route a metre at a time, to no nearer than this, m.
pub(crate) const GOAL_NEAREST_M: f64 = 2.0;
pub(crate) const GOAL_POINTS: usize = 32;
/// Work units, each about one ARA* expansion (~10 us; see the planner
/// README): the traversability graph's growth work (about two nodes on
/// open floor: `TravMap::grow` counts cells and patches read and points
/// fitted), nodes scanned for the start and the goal.
pub(crate) const GROW_PER_UNIT: u64 = 800;
pub(crate) const PICK_PER_UNIT: usize = 128;
/// Candidate scan work per unit: nodes looked at and cells looked up
/// around candidates (a candidate looks at ~110 cells, most nodes at none).
pub(crate) const SCAN_PER_UNIT: u64 = 128;
/// Exploring, the rover waits for its plan: a goal without a path after
/// this many expansions is given up for the next candidate, and a plan
/// not proven optimal this many expansions after the first is driven as it
/// is (its bound is in the plan).
pub(crate) const EXPLORE_GOAL_EXPANSIONS: u64 = 40_000;

/// A query that drove nothing grows the next one's window by this factor.
pub(crate) const WINDOW_GROWTH: f64 = 1.5;
pub(crate) const EXPLORE_IMPROVE_EXPANSIONS: u64 = 20_000;

/// The navigator's settings: the growth window, the query's rhythm and
/// the search's, with the graph's and the lattice's own (serialized by
/// their crates: the configuration writes all three in one table).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(default, deny_unknown_fields)
)]
pub struct NavigatorParams {
    /// Side of the square the graph is grown in, and the most it grows to
    /// after queries that drove nothing, m. The way to a garage ramp's
    /// foot lay outside 30 m from the far side of the level.
    pub window_m: f64,
    pub window_max_m: f64,
    /// Following a route, the goal lies this far ahead along it, m.
    pub goal_ahead_m: f64,
    /// Following a route, a query this long after the last began, s.
    pub replan_every_s: f64,
    /// A query not proven optimal after this many expansions keeps its
    /// best plan.
    pub max_expansions: u64,
    /// ARA*'s first inflation and its fall after each solution.
    pub initial_eps: f64,
    pub eps_step: f64,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub trav: TravParams,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub surface: SurfaceParams,
}

/// The checked rectangle is the body (0.9 x 0.7 m) with this much all
/// round, m: the follower strays from the path by a few centimetres (more
/// backing up).
pub const BODY_MARGIN_M: f64 = 0.05;

impl Default for NavigatorParams {
    /// The simulated Asguard-like rover's (`TravParams` and
    /// `SurfaceParams` describe it), its body checked with
    /// [`BODY_MARGIN_M`] all round, wary of bumps, the graph held to 2^16
    /// nodes.
    fn default() -> Self {
        let s = SurfaceParams::default();
        NavigatorParams {
            window_m: 30.0,
            window_max_m: 60.0,
            goal_ahead_m: 8.0,
            replan_every_s: 10.0,
            max_expansions: 500_000,
            initial_eps: 3.0,
            eps_step: 0.2,
            trav: TravParams {
                max_nodes: 1 << 16,
                ..TravParams::default()
            },
            surface: SurfaceParams {
                body_length_m: s.body_length_m + 2.0 * BODY_MARGIN_M,
                body_width_m: s.body_width_m + 2.0 * BODY_MARGIN_M,
                bump_weight: 10.0,
                ..s
            },
        }
    }
}

pub struct Navigator {
    pub(crate) lat: SurfaceLattice,
    /// Cells of the lattice's map table.
    pub(crate) grid_cells: usize,
    pub(crate) search: AraStar,
    pub(crate) params: AraParams,
    pub(crate) route: Vec<[f64; 2]>,
    pub(crate) looped: bool,
    /// Exploration's goals instead of the route's.
    pub(crate) explore: Option<Box<Exploration>>,
    /// Half the side of the growth window now, as configured, and at most.
    pub(crate) window_half_m: f64,
    pub(crate) window_base_half_m: f64,
    pub(crate) window_max_half_m: f64,
    pub(crate) goal_ahead_m: f64,
    pub(crate) replan_ns: u64,
    pub(crate) max_expansions: u64,
    /// The ground under base_link is about this far down, m.
    pub(crate) base_height_m: f64,
    pub(crate) phase: Phase,
    pub(crate) query: Query,
    pub(crate) next_query_ns: u64,
    pub(crate) candidates: heapless::Vec<(i32, i32, f32), START_CANDIDATES>,
    /// Scratch: the plan's states.
    pub(crate) states: Vec<u32>,
    /// Per solved query: mission time to the first plan and, when proven,
    /// to the optimum, ms; the final bound, thousandths.
    pub first_ms: Vec<u32>,
    pub optimal_ms: Vec<u32>,
    pub final_eps_milli: Vec<u32>,
    pub counters: NavigatorCounters,
    /// The plans published and the exploration's state, for the bus.
    pub(crate) out: Outbox,
}

impl Phase {
    /// The phase's place in [`STEP_PHASES`], for the timed phases.
    pub(crate) fn timed_index(self) -> Option<usize> {
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

impl Navigator {
    /// The navigator as `p` sets it, following `route` (the control
    /// path) until exploration is given, with primitives `prims` at
    /// `resolution_m`; `base_height_m` is base_link's height over the
    /// ground.
    pub fn new(
        p: &NavigatorParams,
        prims: &MprimFile,
        resolution_m: f64,
        route: &[[f64; 2]],
        looped: bool,
        base_height_m: f64,
    ) -> Result<Self, String> {
        let side = (p.window_max_m / resolution_m).ceil() as usize + 2;
        let trav = TravMap::new(TravParams {
            max_window_cells: side * side,
            ..p.trav
        })
        .map_err(|e| e.to_string())?;
        let grid_cells = speleo_planner::surface::grid_cells_for_window(
            p.window_max_m,
            resolution_m,
            &p.surface,
        );
        let lat = SurfaceLattice::new(trav, prims, p.surface.clone(), grid_cells)?;
        if (prims.resolution_m - resolution_m).abs() > 1e-6 * resolution_m {
            return Err(format!(
                "the primitives are for {} m cells, the map has {resolution_m} m",
                prims.resolution_m
            ));
        }
        let search = AraStar::new(lat.max_state_count(), lat.max_successors());
        Ok(Navigator {
            grid_cells,
            lat,
            search,
            params: AraParams {
                initial_eps: p.initial_eps,
                eps_step: p.eps_step,
            },
            route: route.to_vec(),
            looped,
            explore: None,
            window_half_m: p.window_m / 2.0,
            window_base_half_m: p.window_m / 2.0,
            window_max_half_m: p.window_max_m / 2.0,
            goal_ahead_m: p.goal_ahead_m,
            replan_ns: (p.replan_every_s * 1e9) as u64,
            max_expansions: p.max_expansions,
            base_height_m,
            phase: Phase::Idle,
            query: Query::default(),
            next_query_ns: 0,
            candidates: heapless::Vec::new(),
            states: Vec::with_capacity(8192),
            first_ms: Vec::with_capacity(HISTORY),
            optimal_ms: Vec::with_capacity(HISTORY),
            final_eps_milli: Vec::with_capacity(HISTORY),
            counters: NavigatorCounters::default(),
            out: Outbox::new(),
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
}

impl Navigator {
    /// One step of the query under way for `units` of its phase's work
    /// (graph nodes grown, nodes scanned, lattice preparation units,
    /// expansions or internal simulator units): true while there is more
    /// to do now, false when no query could begin or the query ended.
    /// The plans it published and the exploration's state are in
    /// [`Navigator::take_plans`] and [`Navigator::status`].
    pub fn step(&mut self, input: &NavInput, units: u32, host: &mut dyn Rehearsal) -> bool {
        self.out.begin_step();
        if let Some(ex) = &mut self.explore {
            ex.observe(input, &mut self.out);
        }
        let went_on = self.work(input, units.max(1), host);
        went_on && self.phase != Phase::Idle
    }

    /// The timed phase the next step works in (its index in
    /// [`STEP_PHASES`]), or `None` between queries.
    pub fn timed_phase(&self) -> Option<usize> {
        self.phase.timed_index()
    }

    /// The lattice's own stage (map copy, room, cost-to-go), for logs.
    pub fn lattice_stage(&self) -> &'static str {
        self.lat.phase()
    }

    /// Hand over the plans the last step published, oldest first.
    pub fn take_plans(&mut self, publish: impl FnMut(&PlanMsg)) {
        self.out.drain(publish);
    }

    /// The exploration's state as the last step left it.
    pub fn status(&self) -> ExplorationStatus {
        self.out.status
    }
}

impl Navigator {
    /// One step of the phase under way; false when the query could not
    /// begin or go on.
    fn work(&mut self, input: &NavInput, units: u32, host: &mut dyn Rehearsal) -> bool {
        match self.phase {
            Phase::Idle => {
                if !self.begin_query(input, host) {
                    return false;
                }
            }
            Phase::Grow { candidate } => {
                let mls = input.map;
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
                        if ex.explorer.phase() == ExplorerPhase::Exploring {
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
                    trace_cells_near(input.map, rover, GRAPH_TRACE_RADIUS_M);
                }
            }
            Phase::Prepare => {
                if self.lat.prepare(input.map, units as usize) {
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
            Phase::Search => self.search_step(input, units, host),
            Phase::Validate => self.validate(input, units as usize, host),
            Phase::Partial => self.drive_partial(input.now_ns),
        }
        true
    }
}
