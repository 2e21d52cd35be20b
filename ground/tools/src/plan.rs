//! `speleo plan --sbpl-env ENV.cfg --mprim FILE.mprim`: ARA* on an SBPL
//! lattice environment, run in fixed quanta of expansions as the on-board
//! task would, timed round by round.

use std::fmt;
use std::time::Instant;

use serde::Serialize;
use speleo_planner::arastar::{AraParams, AraStar, Lattice, Progress};
use speleo_planner::mprim;
use speleo_planner::sbpl::{parse_env, SbplLattice};

use crate::args::PlanArgs;
use crate::Error;

/// One published solution.
#[derive(Serialize, Debug, Clone)]
pub struct Round {
    pub eps: f64,
    pub cost: u32,
    pub expansions: u64,
    /// Since the search started (the heuristic excluded).
    pub time_s: f64,
}

#[derive(Serialize, Debug)]
pub struct PlanReport {
    pub env: String,
    pub mprim: String,
    pub cells: [usize; 2],
    pub headings: u32,
    pub primitives: usize,
    pub start_cell: [i64; 3],
    pub goal_cell: [i64; 3],
    /// Time to read the files and build the lattice, and to compute the
    /// heuristic (included in `setup_s`).
    pub setup_s: f64,
    /// The heuristic's estimate at the start (a lower bound on the cost).
    pub heuristic_at_start: u32,
    pub rounds: Vec<Round>,
    pub first_solution_s: Option<f64>,
    pub optimal_s: Option<f64>,
    pub expansions: u64,
    /// Optimal cost (SBPL's units), `None` when there is no path.
    pub cost: Option<u32>,
    pub path_length_m: f64,
    /// The path's states as cells and heading bins.
    pub path: Vec<[i64; 3]>,
}

impl fmt::Display for PlanReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} x {} cells, {} headings, {} primitives; setup {:.3} s; heuristic at the start {}",
            self.cells[0],
            self.cells[1],
            self.headings,
            self.primitives,
            self.setup_s,
            self.heuristic_at_start
        )?;
        for r in &self.rounds {
            writeln!(
                f,
                "eps {:.2}: cost {} after {} expansions, {:.3} s",
                r.eps, r.cost, r.expansions, r.time_s
            )?;
        }
        match (self.cost, self.optimal_s) {
            (Some(c), Some(t)) => write!(
                f,
                "optimal cost {c} in {t:.3} s ({} expansions), {} states, {:.3} m",
                self.expansions,
                self.path.len(),
                self.path_length_m
            ),
            _ => write!(f, "no path ({} expansions)", self.expansions),
        }
    }
}

/// A search run to its end, round by round, timed.
pub struct TimedSearch {
    pub rounds: Vec<Round>,
    /// The optimal cost and when it was proven, s.
    pub optimal: Option<(u32, f64)>,
    pub expansions: u64,
    /// The best path's states.
    pub states: Vec<u32>,
}

/// ARA* from `start` to `goal` in quanta of `quantum` expansions, as the
/// on-board task runs it, each published solution timed.
pub fn search_timed<L: Lattice>(
    lat: &L,
    start: u32,
    goal: u32,
    eps: f64,
    eps_step: f64,
    quantum: u32,
) -> TimedSearch {
    let mut search = AraStar::new(lat.state_count(), lat.max_successors());
    let started = Instant::now();
    search.start(
        lat,
        start,
        goal,
        AraParams {
            initial_eps: eps,
            eps_step,
        },
    );
    let mut rounds = Vec::new();
    let mut optimal = None;
    loop {
        let progress = search.step(lat, quantum.max(1));
        let round = |cost, eps| Round {
            eps,
            cost,
            expansions: search.stats().expansions,
            time_s: started.elapsed().as_secs_f64(),
        };
        match progress {
            Progress::Searching => {}
            Progress::Solution { eps_milli, cost } => {
                rounds.push(round(cost, eps_milli as f64 / 1000.0))
            }
            Progress::Optimal { cost } => {
                let r = round(cost, 1.0);
                optimal = Some((cost, r.time_s));
                rounds.push(r);
                break;
            }
            Progress::NoPath | Progress::Idle => break,
        }
    }
    let mut states = Vec::new();
    search.path(&mut states);
    TimedSearch {
        rounds,
        optimal,
        expansions: search.stats().expansions,
        states,
    }
}

pub fn plan_sbpl(a: &PlanArgs) -> Result<PlanReport, Error> {
    let started = Instant::now();
    let read = |p: &std::path::Path| {
        std::fs::read_to_string(p).map_err(|e| format!("cannot read {}: {e}", p.display()))
    };
    let (Some(env_path), Some(mprim_path)) = (&a.sbpl_env, &a.mprim) else {
        return Err("--sbpl-env needs --mprim".into());
    };
    let env = parse_env(&read(env_path)?).map_err(|e| format!("{}: {e}", env_path.display()))?;
    let prims =
        mprim::parse(&read(mprim_path)?).map_err(|e| format!("{}: {e}", mprim_path.display()))?;
    let lat = SbplLattice::new(env, &prims)?;
    let setup_s = started.elapsed().as_secs_f64();
    let timed = search_timed(
        &lat,
        lat.start_state(),
        lat.goal_state(),
        a.eps,
        a.eps_step,
        a.quantum,
    );
    let (rounds, optimal, expansions) = (timed.rounds, timed.optimal, timed.expansions);
    let states = timed.states;
    let cell = |(x, y, t): (i32, i32, u32)| [x as i64, y as i64, t as i64];
    Ok(PlanReport {
        env: env_path.display().to_string(),
        mprim: mprim_path.display().to_string(),
        cells: [lat.env.width, lat.env.height],
        headings: lat.env.angles,
        primitives: prims.primitives.len(),
        start_cell: cell(lat.start),
        goal_cell: cell(lat.goal),
        setup_s,
        heuristic_at_start: lat.heuristic(lat.start_state()),
        first_solution_s: rounds.first().map(|r| r.time_s),
        optimal_s: optimal.map(|o| o.1),
        expansions,
        cost: optimal.map(|o| o.0),
        path_length_m: lat.path_length_m(&states),
        path: states.iter().map(|&s| cell(lat.decode(s))).collect(),
        rounds,
    })
}
