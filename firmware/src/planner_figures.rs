//! The report's `planner` section: what the planner task did over a run.
//! Latencies are mission time from a query's start (the SLAM pose and the
//! point ahead on the route) to its first plan and to its proven optimum,
//! so they count the graph's growth and the lattice's preparation too.

use std::collections::BTreeMap;

use serde::Serialize;
use speleo_scheduler::histogram::Histogram;

use crate::tasks::planner::PlannerTask;
use speleo_navigator::{NavigatorCounters, STEP_PHASES};

#[derive(Clone, Debug, Serialize)]
pub struct PlannerFigures {
    pub calls: u64,
    pub solved: u64,
    pub optimal: u64,
    pub no_start: u64,
    pub no_goal: u64,
    pub no_path: u64,
    pub abandoned: u64,
    pub first_solution_ms_median: Option<f64>,
    pub first_solution_ms_max: Option<u32>,
    pub optimal_ms_median: Option<f64>,
    pub optimal_ms_max: Option<u32>,
    /// Proven bound of the last solved query's final plan (1: optimal).
    pub final_eps: Option<f64>,
    pub final_eps_max: Option<f64>,
    pub expansions: u64,
    pub plans_published: u64,
    pub graph_nodes_max: u64,
    pub graphs_full: u64,
    pub memory_bytes: usize,
    /// Each phase's step times on this machine and the units of its steps:
    /// what `planner.step_units` is calibrated from.
    pub step_us: BTreeMap<&'static str, StepTimes>,
}

#[derive(Clone, Debug, Serialize)]
pub struct StepTimes {
    pub steps: u64,
    /// Units a step did (`planner.step_units`, capped by the quantum).
    pub units: u32,
    pub p50_us: f64,
    pub p999_us: f64,
    pub max_us: f64,
    /// The steps' p99.9 on the thread's CPU clock (preemption left out).
    pub cpu_p999_us: f64,
    /// The CPU times themselves, for pooling runs (`speleo wcet
    /// --calibrate` sizes the units by the work's own time, not by the
    /// time the thread was preempted).
    #[serde(skip)]
    pub cpu_histogram: Histogram,
}

/// The median of a report's figures (not on board: it sorts a copy).
pub(crate) fn median<T: Copy + Into<f64>>(v: &[T]) -> Option<f64> {
    let mut s: Vec<f64> = v.iter().map(|&x| x.into()).collect();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(s[n / 2]),
        _ => Some((s[n / 2 - 1] + s[n / 2]) / 2.0),
    }
}

pub fn figures(t: &PlannerTask, max_nodes: usize) -> PlannerFigures {
    let n = &t.nav;
    let c: NavigatorCounters = n.counters;
    let eps = |m: u32| m as f64 / 1000.0;
    PlannerFigures {
        calls: c.queries,
        solved: c.solved,
        optimal: c.optimal,
        no_start: c.no_start,
        no_goal: c.no_goal,
        no_path: c.no_path,
        abandoned: c.abandoned,
        first_solution_ms_median: median(&n.first_ms),
        first_solution_ms_max: n.first_ms.iter().copied().max(),
        optimal_ms_median: median(&n.optimal_ms),
        optimal_ms_max: n.optimal_ms.iter().copied().max(),
        final_eps: n.final_eps_milli.last().map(|&m| eps(m)),
        final_eps_max: n.final_eps_milli.iter().copied().max().map(eps),
        expansions: c.expansions,
        plans_published: c.plans_published,
        graph_nodes_max: c.nodes_max,
        graphs_full: c.graphs_full,
        memory_bytes: n.memory_bytes(max_nodes),
        step_us: STEP_PHASES
            .iter()
            .zip(t.step_times.iter().zip(t.step_units_run))
            .zip(&t.step_cpu_times)
            .filter(|((_, (h, _)), _)| h.count() > 0)
            .map(|((n, (h, units)), cpu)| {
                let us = |ns: u64| ns as f64 / 1000.0;
                let times = StepTimes {
                    steps: h.count(),
                    units,
                    p50_us: us(h.quantile_ns(0.5)),
                    p999_us: us(h.quantile_ns(0.999)),
                    max_us: us(h.max_ns()),
                    cpu_p999_us: us(cpu.quantile_ns(0.999)),
                    cpu_histogram: cpu.clone(),
                };
                (*n, times)
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::median;

    #[test]
    fn medians_of_odd_and_even_counts() {
        assert_eq!(median::<u32>(&[]), None);
        assert_eq!(median(&[0.5, -1.0]), Some(-0.25));
        assert_eq!(median(&[5, 1, 3]), Some(3.0));
        assert_eq!(median(&[4, 1, 3, 2]), Some(2.5));
    }
}
