//! The schedule: the topology's tasks (`crate::tasks::TOPOLOGY`) with the
//! configuration's `[tasks.NAME]` overrides applied, checked to fit the
//! frame; and the memory budgets of the tasks that may allocate.

use speleo_scheduler::{AnytimeSpec, OverrunPolicy, Schedule, TaskSpec};

use crate::config::{Config, ConfigError};
use crate::tasks::{Node, TASKS, TOPOLOGY};

/// Tasks that call allocating crates and run within a memory budget:
/// slam (the solver's sparse analysis) always; the planner while the
/// internal simulator builds and steps its rapier world. Every other task
/// allocates nothing after start-up.
pub fn allocating_tasks(cfg: &Config) -> &'static [&'static str] {
    if cfg.exploration.enabled && cfg.simulator.enabled {
        &["slam", "planner"]
    } else {
        &["slam"]
    }
}

/// The per-run memory budget of a task that may allocate (see
/// [`allocating_tasks`]): the most heap bytes one run may request.
pub fn memory_budget_kib(cfg: &Config, task: &str) -> Option<u32> {
    if !allocating_tasks(cfg).contains(&task) {
        return None;
    }
    match task {
        "slam" => Some(SLAM_MEMORY_BUDGET_KIB),
        "planner" => Some(PLANNER_MEMORY_BUDGET_KIB),
        _ => None,
    }
}

/// SLAM's solver: the symbolic analysis of the graph after a change.
/// `speleo wcet` measured at most 4.0 MiB in a run (route, 300 s).
pub const SLAM_MEMORY_BUDGET_KIB: u32 = 8 * 1024;
/// The internal simulator's TSDF, tiles and rapier world, built within
/// runs: `speleo wcet --scenario validate` measured 10.6 MiB in a run.
pub const PLANNER_MEMORY_BUDGET_KIB: u32 = 32 * 1024;

/// The task table with the configuration's overrides applied.
pub fn specs(cfg: &Config) -> Result<Vec<TaskSpec>, ConfigError> {
    let mut specs: Vec<TaskSpec> = TOPOLOGY.iter().map(Node::spec).collect();
    for (name, o) in &cfg.tasks {
        let Some(spec) = specs.iter_mut().find(|s| s.name.as_str() == name) else {
            return Err(ConfigError::Invalid {
                key: format!("tasks.{name}"),
                why: format!(
                    "there is no task named \"{name}\" (tasks: {})",
                    TASKS.join(", ")
                ),
            });
        };
        if let Some(d) = o.divisor {
            spec.rate.divisor = d;
        }
        if let Some(off) = o.offset {
            spec.rate.offset = off;
        }
        if let Some(b) = o.budget_us {
            spec.budget_us = b;
        }
        if let Some(p) = &o.policy {
            spec.policy = OverrunPolicy::parse(p).ok_or_else(|| ConfigError::Invalid {
                key: format!("tasks.{name}.policy"),
                why: format!("unknown policy \"{p}\""),
            })?;
        }
        match (&mut spec.anytime, o.steps, o.quantum, o.window_us) {
            (_, None, None, None) => {}
            (Some(a), steps, quantum, window) => {
                *a = AnytimeSpec {
                    steps: steps.unwrap_or(a.steps),
                    quantum: quantum.unwrap_or(a.quantum),
                    window_us: window.unwrap_or(a.window_us),
                };
            }
            (None, ..) => {
                return Err(ConfigError::Invalid {
                    key: format!("tasks.{name}"),
                    why: "steps, quantum and window_us apply only to anytime tasks".into(),
                })
            }
        }
    }
    Ok(specs)
}

/// Build and check the schedule; an unschedulable table is refused with the
/// frame and tasks that do not fit.
pub fn build(cfg: &Config) -> Result<Schedule, ConfigError> {
    let specs = specs(cfg)?;
    Schedule::build(
        cfg.executive.minor_frame_us,
        cfg.executive.margin_us,
        &specs,
    )
    .map_err(|e| ConfigError::Invalid {
        key: "tasks".into(),
        why: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_table_fits() {
        let s = build(&Config::default()).expect("schedulable");
        assert_eq!(s.tasks().len(), TASKS.len());
        for (spec, name) in s.tasks().iter().zip(TASKS) {
            assert_eq!(spec.name.as_str(), name);
        }
    }

    #[test]
    fn a_budget_that_cannot_fit_is_refused_with_frame_and_tasks() {
        let cfg = Config::from_toml("[tasks.control]\nbudget_us = 8000\n").expect("valid syntax");
        let e = build(&cfg).expect_err("overbooked");
        let m = e.to_string();
        assert!(m.contains("unschedulable"), "{m}");
        assert!(m.contains("minor frame 1"), "{m}");
        assert!(m.contains("control 8000 us"), "{m}");
    }

    #[test]
    fn an_unknown_task_is_named() {
        let cfg = Config::from_toml("[tasks.navigator]\nbudget_us = 10\n").expect("valid syntax");
        let m = build(&cfg).expect_err("unknown").to_string();
        assert!(m.contains("tasks.navigator"), "{m}");
    }
}
