//! The exploration behaviour inside the planner task: when a traverse is
//! over and the maps have settled, a query grows the graph, scans it for
//! candidates and plans to them in turn; the first plan found is handed to
//! the control task to drive. When nothing is left, or time is up, the
//! goals come from the rover's track home instead.

use speleo_exploration::{CandidateParams, CandidateScan, Explorer, ExplorerParams, Mode};

use crate::bus::{Bus, ExplorationPhase, ExplorationStatus};

/// What the exploration did, for the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExplorationCounters {
    /// Queries that scanned for candidates, and those that found none.
    pub scans: u64,
    pub scans_empty: u64,
    /// Goals planned to (candidates and points home), and those with no path.
    pub goals_attempted: u64,
    pub goals_unreachable: u64,
    /// Plans handed to the control task.
    pub plans_executed: u64,
}

pub struct Exploration {
    pub explorer: Explorer,
    pub scan: CandidateScan,
    pub target: Option<[f64; 2]>,
    settle_ns: u64,
    /// The first SLAM pose has become home.
    homed: bool,
    /// The query whose plan the control task was given (0: none yet).
    pub executing: u64,
    /// Since when the control task has been seen idle.
    idle_since: Option<u64>,
    last_observed: [f64; 2],
    pub counters: ExplorationCounters,
}

impl Exploration {
    /// All storage taken now (the coverage map around the origin).
    pub fn new(
        e: ExplorerParams,
        c: CandidateParams,
        target: Option<[f64; 2]>,
        settle_s: f64,
    ) -> Self {
        Exploration {
            explorer: Explorer::new(e, [0.0; 3]),
            scan: CandidateScan::new(c),
            target,
            settle_ns: (settle_s * 1e9) as u64,
            homed: false,
            executing: 0,
            idle_since: None,
            last_observed: [f64::INFINITY; 2],
            counters: ExplorationCounters::default(),
        }
    }

    pub fn mode(&self) -> Mode {
        self.explorer.mode()
    }

    /// Every frame: follow the rover's pose; publish the state.
    pub fn observe(&mut self, bus: &mut Bus, now: u64) {
        if let Some(p) = bus.slam.get().map(|p| p.value.position) {
            if !self.homed {
                self.explorer.restart(p);
                self.homed = true;
            }
            // Coverage and track change only as the rover moves.
            let moved = (p[0] - self.last_observed[0]).hypot(p[1] - self.last_observed[1]);
            if moved >= 0.1 || now % 1_000_000_000 < 1_000_000 {
                self.explorer.observe(now as f64 * 1e-9, p);
                self.last_observed = [p[0], p[1]];
            }
        }
        bus.exploration = ExplorationStatus {
            phase: match self.explorer.mode() {
                Mode::Exploring => ExplorationPhase::Exploring,
                Mode::Returning(_) => ExplorationPhase::Returning,
                Mode::Finished(_) => ExplorationPhase::Finished,
            },
            goal: bus.exploration.goal,
        };
    }

    /// Whether a query may begin: home is known, the mission is not over,
    /// the control task has finished the last plan (or has none) and the
    /// maps have had `settle_s` since.
    pub fn ready(&mut self, bus: &Bus, now: u64) -> bool {
        if !self.homed || matches!(self.explorer.mode(), Mode::Finished(_)) {
            return false;
        }
        let idle = self.executing == 0
            || bus
                .command
                .get()
                .is_some_and(|c| c.value.plan == self.executing && c.value.done);
        if !idle {
            self.idle_since = None;
            return false;
        }
        if self.idle_since.is_none() {
            // The traverse is over: a goal the rover was stopped on the way
            // to is not tried again.
            let stopped = bus.command.get().is_some_and(|c| c.value.stop != 0);
            if let (true, Mode::Exploring, Some(g)) =
                (stopped, self.explorer.mode(), bus.exploration.goal)
            {
                self.explorer.reject([g[0], g[1]]);
            }
        }
        let since = *self.idle_since.get_or_insert(now);
        if now < since + self.settle_ns {
            return false;
        }
        self.idle_since = None;
        true
    }
}
