//! `speleo wcet`: worst-case scenarios run through the executive, and each
//! periodic task's execution times on this machine against its budget.
//!
//! The scenarios load the tasks where they work hardest: the route mission
//! (drivers, odometry, SLAM keyframes, maps, planner queries along the
//! route), exploration (candidate scans and queries one after another),
//! exploration with every plan driven in the internal simulator first,
//! the boulder field (the most obstacles the planner checks bodies
//! against), the garage (concrete walls and slabs all around: the densest
//! LiDAR returns) and the replay of a recorded route mission.
//!
//! A task passes when the p99.9 of its execution time is within its budget
//! and, for the tasks that may allocate, no run requested more heap than its
//! memory budget. The execution time is the frame thread's CPU time where
//! the platform measures it (Linux), the wall clock elsewhere: on a shared
//! machine without real-time priority the wall clock adds whatever other
//! processes preempted the thread for, which on the rover its SCHED_FIFO
//! priority keeps out (`speleo run` reports what preemption is left as
//! frame start lateness and deadline misses). A neighbour's load still
//! counts where it slows the work itself (caches, memory bandwidth). The
//! wall-clock p99.9 and maximum are printed beside it but not judged. Each
//! scenario also shows the heap's high-water mark and how much its second
//! half raised it.

use std::path::PathBuf;
use std::process::ExitCode;

use serde::Serialize;

use speleo_firmware::args::Outputs;
use speleo_firmware::config::{Config, STEP_PHASES};
use speleo_firmware::mission::{MissionResult, TaskFigures};
mod calibration;

use calibration::planner_calibration;

type Error = Box<dyn std::error::Error>;

/// One worst-case scenario.
pub struct Scenario {
    pub name: &'static str,
    pub about: &'static str,
    world: &'static str,
    duration_s: f64,
    configure: fn(&mut Config),
    /// Recorded, then replayed; the replay's times are judged.
    replay: bool,
}

fn route(c: &mut Config) {
    c.exploration.enabled = false;
}

/// Exploring without the internal simulator: the planner's queries come
/// back to back (the `validate` scenario has the simulator).
fn explore(c: &mut Config) {
    c.exploration.enabled = true;
    c.simulator.enabled = false;
}

fn explore_and_validate(c: &mut Config) {
    c.exploration.enabled = true;
    c.simulator.enabled = true;
}

pub const SCENARIOS: [Scenario; 6] = [
    Scenario {
        name: "route",
        about: "the lava tube's route: every task of the default mission",
        world: "lava-tube",
        duration_s: 300.0,
        configure: route,
        replay: false,
    },
    Scenario {
        name: "explore",
        about: "the short tube explored: candidate scans and queries back to back",
        world: "short-tube",
        duration_s: 300.0,
        configure: explore,
        replay: false,
    },
    Scenario {
        name: "validate",
        about: "the short tube explored, every plan driven in the internal simulator first",
        world: "short-tube",
        duration_s: 300.0,
        configure: explore_and_validate,
        replay: false,
    },
    Scenario {
        name: "boulders",
        about: "the boulder field explored: the most obstacles around the body checks",
        world: "boulders",
        duration_s: 200.0,
        configure: explore,
        replay: false,
    },
    Scenario {
        name: "garage",
        about: "the garage explored: walls, slabs and roofs all around, the densest returns",
        world: "garage",
        duration_s: 200.0,
        configure: explore,
        replay: false,
    },
    Scenario {
        name: "replay",
        about: "a recorded route mission replayed through the drivers and tasks",
        world: "lava-tube",
        duration_s: 120.0,
        configure: route,
        replay: true,
    },
];

#[derive(Debug, Serialize)]
pub struct TaskVerdict {
    pub name: String,
    pub budget_us: u32,
    pub runs: u64,
    pub max_us: f64,
    pub p99_us: f64,
    pub p999_us: f64,
    /// The p99.9 on the thread's CPU clock (preemption left out).
    pub cpu_p999_us: Option<f64>,
    pub overruns: u64,
    pub alloc_bytes_max_run: u64,
    pub memory_budget_kib: Option<u32>,
    pub pass: bool,
}

#[derive(Debug, Serialize)]
pub struct ScenarioReport {
    pub name: String,
    pub about: String,
    pub world: String,
    pub sim_time_s: f64,
    pub wall_time_s: f64,
    pub memory: Option<speleo_firmware::mission::MemoryFigures>,
    /// The planner's step times by phase, from which its units are sized.
    pub planner_step_us: Option<
        std::collections::BTreeMap<&'static str, speleo_firmware::planner_figures::StepTimes>,
    >,
    pub tasks: Vec<TaskVerdict>,
    pub pass: bool,
}

#[derive(Debug, Serialize)]
pub struct WcetReport {
    pub criterion: &'static str,
    pub scenarios: Vec<ScenarioReport>,
    pub pass: bool,
}

/// The verdict on one run's task times.
pub fn judge(s: &Scenario, r: &MissionResult) -> ScenarioReport {
    let tasks = verdicts(&r.tasks);
    ScenarioReport {
        name: s.name.into(),
        about: s.about.into(),
        world: s.world.into(),
        sim_time_s: r.sim_time_s,
        wall_time_s: r.wall_time_s,
        memory: r.memory,
        planner_step_us: r.planner.as_ref().map(|p| p.step_us.clone()),
        pass: tasks.iter().all(|t| t.pass),
        tasks,
    }
}

/// Each task's times against its budget.
pub fn verdicts(tasks: &[TaskFigures]) -> Vec<TaskVerdict> {
    tasks
        .iter()
        .map(|t| TaskVerdict {
            name: t.name.clone(),
            budget_us: t.budget_us,
            runs: t.runs,
            max_us: t.max_us,
            p99_us: t.p99_us,
            p999_us: t.p999_us,
            cpu_p999_us: t.cpu_p999_us,
            overruns: t.overruns,
            alloc_bytes_max_run: t.alloc_bytes_max_run,
            memory_budget_kib: t.memory_budget_kib,
            pass: (t.runs == 0 || t.cpu_p999_us.unwrap_or(t.p999_us) <= t.budget_us as f64)
                && t.memory_budget_kib
                    .is_none_or(|kib| t.alloc_bytes_max_run <= kib as u64 * 1024),
        })
        .collect()
}

fn run_scenario(s: &Scenario, base: &Config, progress: bool) -> Result<ScenarioReport, Error> {
    let mut cfg = base.clone();
    cfg.sim.world = s.world.into();
    cfg.sim.duration_s = s.duration_s;
    (s.configure)(&mut cfg);
    if !s.replay {
        let r = speleo_firmware::commands::simulate(&mut cfg, &Outputs::default(), progress)?;
        return Ok(judge(s, &r));
    }
    let dir = std::env::temp_dir().join(format!("speleo-wcet-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let log = dir.join("route.mcap");
    let recorded = Outputs {
        record: Some(log.clone()),
        ..Outputs::default()
    };
    speleo_firmware::commands::simulate(&mut cfg, &recorded, progress)?;
    let replayed = speleo_firmware::commands::replay_recording(&log, &Outputs::default(), progress);
    let _ = std::fs::remove_dir_all(&dir);
    let r = replayed?;
    if let Some(d) = r.divergence {
        return Err(format!("the replay diverged from its recording: {d}").into());
    }
    Ok(judge(s, &r.result))
}

fn print(s: &ScenarioReport) {
    println!(
        "{} ({}, {:.0} s simulated in {:.0} s): {}",
        s.name,
        s.world,
        s.sim_time_s,
        s.wall_time_s,
        if s.pass { "pass" } else { "FAIL" }
    );
    if let Some(m) = &s.memory {
        println!(
            "  heap high-water {:.1} MB, raised {:.1} kB in the second half",
            m.heap_peak_bytes as f64 * 1e-6,
            m.heap_peak_growth_bytes as f64 * 1e-3
        );
    }
    if let Some(steps) = &s.planner_step_us {
        let phases: Vec<String> = steps
            .iter()
            .map(|(n, t)| format!("{n} {:.0}/{:.0} ({})", t.p50_us, t.p999_us, t.units))
            .collect();
        println!(
            "  planner steps by phase, p50/p99.9 us (units): {}",
            phases.join(", ")
        );
    }
    println!(
        "  {:<13} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>17}  verdict",
        "task", "budget", "max", "p99", "p99.9", "cpu p99.9", "overruns", "heap/run (budget)"
    );
    for t in &s.tasks {
        let heap = match t.memory_budget_kib {
            Some(kib) => format!("{}k ({kib}k)", t.alloc_bytes_max_run.div_ceil(1024)),
            None => format!("{}k", t.alloc_bytes_max_run.div_ceil(1024)),
        };
        let cpu = t
            .cpu_p999_us
            .map_or_else(|| "-".to_string(), |c| format!("{c:.0}us"));
        println!(
            "  {:<13} {:>6}us {:>7.0}us {:>7.0}us {:>7.0}us {:>9} {:>9} {:>17}  {}",
            t.name,
            t.budget_us,
            t.max_us,
            t.p99_us,
            t.p999_us,
            cpu,
            t.overruns,
            heap,
            if t.pass { "pass" } else { "FAIL" }
        );
    }
}

/// A recording (a bench's, the rover's, a simulation's) replayed through
/// the drivers and tasks, its times judged as a scenario's are.
fn run_recording(log: &std::path::Path, progress: bool) -> Result<ScenarioReport, Error> {
    let r = speleo_firmware::commands::replay_recording(log, &Outputs::default(), progress)?;
    if let Some(d) = r.divergence {
        return Err(format!("the replay diverged from its recording: {d}").into());
    }
    let tasks = verdicts(&r.result.tasks);
    Ok(ScenarioReport {
        name: "recording".into(),
        about: format!("{} replayed through the drivers and tasks", log.display()),
        world: log
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        sim_time_s: r.result.sim_time_s,
        wall_time_s: r.result.wall_time_s,
        memory: r.result.memory,
        planner_step_us: r.result.planner.as_ref().map(|p| p.step_us.clone()),
        pass: tasks.iter().all(|t| t.pass),
        tasks,
    })
}

/// `speleo wcet`: the scenarios, or one recording when `recording` is given.
pub fn wcet(
    scenario: Option<&str>,
    recording: Option<&PathBuf>,
    config: Option<&PathBuf>,
    report: Option<&PathBuf>,
    calibrate: Option<&PathBuf>,
    progress: bool,
) -> Result<ExitCode, Error> {
    let base = match config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    let chosen: Vec<&Scenario> = match scenario {
        _ if recording.is_some() => Vec::new(),
        None => SCENARIOS.iter().collect(),
        Some(n) => {
            let s = SCENARIOS.iter().find(|s| s.name == n).ok_or_else(|| {
                let names: Vec<_> = SCENARIOS.iter().map(|s| s.name).collect();
                format!("no scenario \"{n}\" (scenarios: {})", names.join(", "))
            })?;
            vec![s]
        }
    };
    println!(
        "judged: each task's p99.9 CPU time against its budget (the wall clock's, with preemption, beside it)"
    );
    let mut scenarios = Vec::new();
    if let Some(log) = recording {
        let r = run_recording(log, progress)?;
        print(&r);
        scenarios.push(r);
    }
    for s in chosen {
        let r = run_scenario(s, &base, progress)?;
        print(&r);
        scenarios.push(r);
    }
    let out = WcetReport {
        criterion: "p99.9 of the execution time (the thread's CPU time where measured) within the time budget; heap per run within the memory budget",
        pass: scenarios.iter().all(|s| s.pass),
        scenarios,
    };
    if let Some(p) = report {
        speleo_firmware::report::write_json(p, &out)?;
    }
    if let Some(p) = calibrate {
        write_calibration(p, &base, &out.scenarios)?;
    }
    println!("wcet: {}", if out.pass { "pass" } else { "FAIL" });
    Ok(if out.pass {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// `--calibrate`: the planner's units per phase from this run's step times.
fn write_calibration(
    path: &PathBuf,
    base: &Config,
    scenarios: &[ScenarioReport],
) -> Result<(), Error> {
    let spec = speleo_firmware::schedule_table::specs(base)?
        .into_iter()
        .find(|s| s.name.as_str() == "planner")
        .and_then(|s| s.anytime)
        .ok_or("the planner is not an anytime task in this configuration")?;
    let current = base.planner.step_units;
    let Some(c) = planner_calibration(scenarios, current, spec.window_us) else {
        println!("calibration: no planner step was measured; nothing written");
        return Ok(());
    };
    std::fs::write(path, c.to_toml()).map_err(|e| format!("writing {}: {e}", path.display()))?;
    println!(
        "calibration: planner units per step, written to {}",
        path.display()
    );
    for ((name, was), now) in STEP_PHASES
        .iter()
        .zip(current.as_array())
        .zip(c.units.as_array())
    {
        let from = c.measured.iter().find(|m| m.phase == *name);
        match from {
            Some(m) => println!(
                "  {name:<10} {now:>4} (was {was}; {:.1} us a unit at p99.9 over {} steps)",
                m.unit_us(),
                m.steps
            ),
            None => println!(
                "  {name:<10} {now:>4} (kept: fewer than {} steps of it measured)",
                calibration::MIN_STEPS
            ),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn task(p999_us: f64, max_us: f64, runs: u64) -> TaskFigures {
        TaskFigures {
            name: "maps".into(),
            period_us: 20_000,
            budget_us: 900,
            policy: "skip".into(),
            runs,
            max_us,
            p50_us: 100.0,
            p99_us: p999_us,
            p999_us,
            cpu_p99_us: None,
            cpu_p999_us: None,
            cpu_max_us: None,
            overruns: 0,
            skipped: 0,
            allocations: 0,
            alloc_bytes_max_run: 0,
            memory_budget_kib: None,
        }
    }

    #[test]
    fn a_task_is_judged_on_its_cpu_time_where_it_was_measured() {
        // Preempted for 2 ms at p99.9 on the wall clock; 0.8 ms of work.
        let mut preempted = task(2_800.0, 9_000.0, 100);
        preempted.cpu_p999_us = Some(800.0);
        let mut slow = task(950.0, 950.0, 100);
        slow.cpu_p999_us = Some(920.0);
        let v = verdicts(&[preempted, slow]);
        assert_eq!(v.iter().map(|t| t.pass).collect::<Vec<_>>(), [true, false]);
    }

    #[test]
    fn a_task_passes_on_its_p999_and_not_its_max() {
        let v = verdicts(&[
            task(850.0, 5_000.0, 100),
            task(950.0, 950.0, 100),
            task(0.0, 0.0, 0),
        ]);
        assert_eq!(
            v.iter().map(|t| t.pass).collect::<Vec<_>>(),
            [true, false, true]
        );
    }

    #[test]
    fn a_task_over_its_memory_budget_fails() {
        let mut within = task(100.0, 100.0, 10);
        within.memory_budget_kib = Some(4);
        within.alloc_bytes_max_run = 4096;
        let mut over = within.clone();
        over.alloc_bytes_max_run = 4097;
        let v = verdicts(&[within, over]);
        assert_eq!(v.iter().map(|t| t.pass).collect::<Vec<_>>(), [true, false]);
    }

    #[test]
    fn scenario_names_are_unique_and_their_worlds_exist() {
        for (i, s) in SCENARIOS.iter().enumerate() {
            assert!(
                SCENARIOS[..i].iter().all(|o| o.name != s.name),
                "{}",
                s.name
            );
            assert!(speleo_twin::world::NAMES.contains(&s.world), "{}", s.world);
        }
    }
}
