//! A query's phases and its state: from the pose it began at to the goal
//! it is planning to.

use speleo_exploration::ExplorerPhase;
use speleo_mapping::mls::MlsMap;
use speleo_messages::attitude::yaw_of;
use speleo_traversability::Window;

use crate::input::NavInput;
use crate::pick::{point_ahead, start_candidates};
use crate::rehearsal::Rehearsal;
use crate::{Navigator, GOAL_NEAREST_M, GOAL_POINTS, HISTORY, WINDOW_GROWTH};

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Phase {
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
pub(crate) struct Query {
    pub(crate) began_ns: u64,
    pub(crate) rover: [f64; 3],
    pub(crate) yaw: f64,
    /// The rover's attitude (w, x, y, z): the internal simulation starts
    /// it as it stands.
    pub(crate) attitude: [f64; 4],
    /// Points along the route, farthest first (with the route's heading
    /// there).
    pub(crate) goals: [([f64; 2], f64); GOAL_POINTS],
    /// The height of each goal point where it has one (the track's).
    pub(crate) goal_z: [Option<f64>; GOAL_POINTS],
    pub(crate) goal_count: usize,
    /// The start node and, per goal point, the node found so far, with
    /// their distances².
    pub(crate) start: Option<(u32, f64)>,
    pub(crate) goal: [Option<(u32, f64)>; GOAL_POINTS],
    pub(crate) start_state: u32,
    /// Goal nodes to try in turn and their positions, and the one tried.
    pub(crate) order: [(u32, [f64; 3]); GOAL_POINTS],
    pub(crate) order_len: usize,
    pub(crate) tried: usize,
    pub(crate) solved: bool,
    /// Proven bound of the last plan, thousandths, and its cost.
    pub(crate) eps_milli: u32,
    pub(crate) cost: u32,
    /// Expansions when the first plan was found.
    pub(crate) solved_at: u64,
    /// The plan under validation: its (cost, bound) and optimality.
    pub(crate) best: ((u32, u32), bool),
    /// The plan under validation is a retrace of the track.
    pub(crate) retrace: bool,
}

impl Navigator {
    /// Begin a query if one is due and possible.
    pub(crate) fn begin_query(&mut self, input: &NavInput, host: &mut dyn Rehearsal) -> bool {
        let now = input.now_ns;
        let Some(pose) = input.slam.map(|p| p.value) else {
            return false;
        };
        match &mut self.explore {
            Some(ex) => {
                if !ex.ready(input, &self.out) {
                    return false;
                }
                if ex.retrace_due() {
                    // No plan home from here: back the way the rover came.
                    self.counters.queries += 1;
                    let check = ex.retrace(
                        input,
                        &mut self.out,
                        self.counters.queries,
                        self.goal_ahead_m,
                    );
                    self.counters.plans_published += 1;
                    return check && self.validate_retrace(input, host, &pose);
                }
            }
            None => {
                if now < self.next_query_ns || self.route.len() < 2 {
                    return false;
                }
            }
        }
        let mls = input.map;
        if mls.stats().cells == 0 {
            return false;
        }
        self.next_query_ns = now + self.replan_ns;
        self.counters.queries += 1;
        let segment = input.command.map_or(0, |c| c.value.segment as usize);
        self.query = Query {
            began_ns: now,
            rover: pose.position,
            yaw: yaw_of(pose.orientation),
            attitude: pose.orientation,
            ..Query::default()
        };
        if let Some(ex) = &self.explore {
            // Exploring: candidates come after the graph is grown.
            if matches!(ex.phase(), ExplorerPhase::Returning(_)) {
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
        self.begin_growth(input.map, 0)
    }

    /// Grow from start candidate `k` (or the next that has ground).
    pub(crate) fn begin_growth(&mut self, mls: &MlsMap, mut k: usize) -> bool {
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
    pub(crate) fn end_query(&mut self) {
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
}
