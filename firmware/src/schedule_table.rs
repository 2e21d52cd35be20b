//! The schedule table: which tasks exist, in which order they run within a
//! frame, and their default rate groups, budgets and overrun policies. The
//! configuration's `[tasks.NAME]` tables override the defaults.

use speleo_scheduler::{AnytimeSpec, OverrunPolicy, RateGroup, Schedule, TaskSpec};

use crate::config::{Config, ConfigError};

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

/// The internal simulator's batch on its worker core
/// (`[simulator] worker_units`): it has the frame, less the hand-overs.
pub const SIM_WORKER_BUDGET_US: u32 = 8_000;

/// Task names in execution order.
pub const TASKS: [&str; 12] = [
    "io",
    "lidar_driver",
    "imu_driver",
    "drive_driver",
    "odometry",
    "slam",
    "maps",
    "planner",
    "control",
    "drive_output",
    "health",
    "recorder",
];

/// The most work units of one planner step: each phase does its own
/// `planner.step_units` (calibrated with `speleo wcet --calibrate`), capped
/// by this quantum.
pub const PLANNER_QUANTUM: u32 = crate::config::MAX_STEP_UNITS;

fn defaults() -> Vec<TaskSpec> {
    use OverrunPolicy::*;
    let every = RateGroup::EVERY_FRAME;
    vec![
        // Moves the frame's bytes between the devices and the bus (max
        // ~50 us measured in sim).
        TaskSpec::periodic("io", every, 400, Skip).safe(),
        // ~18 packets (6,700 points) a frame, decoded at ~90 M points/s; once a
        // revolution (~70k points) is handed over: ~0.2 ms more.
        TaskSpec::periodic("lidar_driver", every, 1_000, Skip).safe(),
        TaskSpec::periodic("imu_driver", every, 300, Skip).safe(),
        TaskSpec::periodic("drive_driver", every, 300, Skip).safe(),
        // Also in safe mode: a stopped rover keeps knowing where it is, and
        // the health task keeps seeing its wheels.
        TaskSpec::periodic("odometry", every, 300, ReuseLast).safe(),
        // One bounded unit of keyframe work a frame (a part of a cloud's
        // preparation or of a GICP pass, the insertion, the solver's analysis,
        // a slice of factors of an LM iteration or its factorisation).
        TaskSpec::anytime(
            "slam",
            every,
            2_000,
            Skip,
            AnytimeSpec {
                quantum: 1,
                steps: 1,
                window_us: 2_000,
            },
        ),
        // The multi-level surface map: one part of a keyframe's cloud
        // (maps.points_per_step points, ~0.4 ms) in the even frames, where
        // control does not run and 0.9 ms are free.
        TaskSpec::anytime(
            "maps",
            RateGroup::new(2, 0),
            900,
            Skip,
            AnytimeSpec {
                quantum: 1,
                steps: 1,
                window_us: 900,
            },
        ),
        // The planner: one phase's quantum a frame (graph nodes grown,
        // lattice units prepared, or ARA* expansions).
        TaskSpec::anytime(
            "planner",
            every,
            1_000,
            Skip,
            AnytimeSpec {
                quantum: PLANNER_QUANTUM,
                steps: 1,
                window_us: 1_000,
            },
        ),
        // 50 Hz path following, in the odd frames.
        TaskSpec::periodic("control", RateGroup::new(2, 1), 500, Degrade),
        TaskSpec::periodic("drive_output", every, 200, SafeMode).safe(),
        // 10 Hz health, offset to spread the load.
        TaskSpec::periodic("health", RateGroup::new(10, 5), 200, Skip).safe(),
        // Chunk compression peaks at ~1.9 ms.
        TaskSpec::periodic("recorder", every, 2_400, Degrade).safe(),
    ]
}

/// The task table with the configuration's overrides applied.
pub fn specs(cfg: &Config) -> Result<Vec<TaskSpec>, ConfigError> {
    let mut specs = defaults();
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
