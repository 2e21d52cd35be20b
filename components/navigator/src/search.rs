//! Planning to one goal: its checks before the search, the search's steps,
//! and the plans it publishes.

use speleo_exploration::ExplorerPhase;
use speleo_messages::PlanMsg;
use speleo_planner::arastar::Progress;

use crate::input::NavInput;
use crate::query::Phase;
use crate::rehearsal::Rehearsal;
use crate::{Navigator, EXPLORE_GOAL_EXPANSIONS, EXPLORE_IMPROVE_EXPANSIONS, HISTORY};

impl Navigator {
    /// Plan to the `k`-th goal in order (any heading at the goal: the next
    /// query starts from wherever the rover is by then).
    pub(crate) fn try_goal(&mut self, k: usize) -> Phase {
        let partial = self.explore.as_ref().is_some_and(|ex| {
            !ex.partial.poses.is_empty() && ex.phase() == ExplorerPhase::Exploring
        });
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
                phase = ?ex.phase(),
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

    /// Whether the exploration goal being tried stands over a rock (see
    /// `CandidateParams::max_rock_m`, and the planner's `max_bump_m`, which
    /// no path would pass): then it is refused, its place rejected, and
    /// the next goal tried.
    pub(crate) fn goal_on_a_rock(&mut self) -> bool {
        let Some(ex) = self.explore.as_deref_mut() else {
            return false;
        };
        if ex.phase() != ExplorerPhase::Exploring {
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
    pub(crate) fn goal_failed(&mut self, why: &'static str) {
        let Some(ex) = &mut self.explore else {
            self.counters.no_path += 1;
            self.end_query();
            return;
        };
        tracing::debug!(
            why,
            expansions = self.search.stats().expansions,
            window_m = 2.0 * self.window_half_m,
            met_window_edge = self.lat.met_window_edge(),
            "no path to the goal"
        );
        ex.counters.goals_unreachable += 1;
        let at = self.query.order[self.query.tried].1;
        // The way to a goal may leave the window (from the far side of a
        // level, or to a goal above the start): a search that
        // ran into the window's border proves nothing until the window is
        // as large as it gets. One that never met the border would search
        // the same states in a larger window, and fail again.
        let proven = self.window_half_m >= self.window_max_half_m || !self.lat.met_window_edge();
        if ex.phase() == ExplorerPhase::Exploring && proven {
            ex.explorer.reject([at[0], at[1]]);
        }
        self.phase = self.try_goal(self.query.tried + 1);
    }

    /// Publish the best plan so far.
    pub(crate) fn publish(&mut self, (cost, eps_milli): (u32, u32), optimal: bool, execute: bool) {
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
                self.out.status.goal = Some(self.query.order[self.query.tried].1);
            }
        }
        self.out.publish(msg);
    }

    /// Milliseconds of mission time since the query began.
    pub(crate) fn since_query_ms(&self, now: u64) -> u32 {
        ((now.saturating_sub(self.query.began_ns)) / 1_000_000).min(u32::MAX as u64) as u32
    }

    pub(crate) fn search_step(&mut self, input: &NavInput, units: u32, host: &mut dyn Rehearsal) {
        let now = input.now_ns;
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
                            self.plan_found(input, host, best, false);
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
                self.publish((cost, eps_milli), false, false);
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
                    self.plan_found(input, host, (cost, 1000), true);
                } else {
                    self.publish((cost, 1000), true, false);
                    self.end_query();
                }
            }
            Progress::NoPath | Progress::Idle => self.goal_failed("search exhausted"),
        }
    }

    /// A plan exists: the first one's latency is kept.
    pub(crate) fn solution(&mut self, now: u64) {
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
