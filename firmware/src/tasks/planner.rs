//! The planner task: the navigator (`speleo_navigator`) as an anytime
//! task. Each step reads the mailboxes, has the navigator do one phase's
//! work for that phase's units (`planner.step_units`, at most the
//! scheduler's quantum), publishes the plans it made and the exploration's
//! state, and times the step for the units' calibration.

use speleo_messages::DriveFeedback;
use speleo_navigator::{Exploration, NavInput, Navigator, STEP_PHASES};
use speleo_planner::primitives;
use speleo_scheduler::histogram::Histogram;
use speleo_scheduler::mailbox::Stamped;
use speleo_scheduler::realtime::thread_cpu_ns;
use speleo_scheduler::{Context, StepResult, Task};
use speleo_slam::lie::Pose;

use speleo_simulator::InternalSim;

use crate::bus::Bus;
use crate::config::Config;
use crate::params;
use crate::simulator_clouds::MapClouds;
use crate::simulator_host::{SimulatorHost, SimulatorWorker};
use crate::validation_dump::ValidationDump;

/// A step this long on the thread's CPU clock is logged (debug), ns.
const SLOW_STEP_NS: u64 = 1_000_000;

pub struct PlannerTask {
    pub nav: Navigator,
    /// The internal simulator's worker and the validations' record.
    pub host: SimulatorHost,
    /// The LiDAR mount (base <- sensor): the keyframe clouds' frame.
    mount: Pose,
    /// Each phase's step times (by [`STEP_PHASES`]), for calibrating its
    /// units: measured only, never acted on, so outputs stay the same.
    pub step_times: [Histogram; STEP_PHASES.len()],
    /// The same steps on the thread's CPU clock (preemption left out).
    pub step_cpu_times: [Histogram; STEP_PHASES.len()],
    /// Units a step of each phase does (`planner.step_units`)...
    step_units: [u32; STEP_PHASES.len()],
    /// ...and did, capped by the scheduler's quantum (0: no step yet).
    pub step_units_run: [u32; STEP_PHASES.len()],
}

impl PlannerTask {
    /// `nav` stepped `step_units` a phase, its simulation hosted by `host`
    /// over the keyframe clouds seen through `mount`.
    pub fn new(
        nav: Navigator,
        step_units: [u32; STEP_PHASES.len()],
        host: SimulatorHost,
        mount: Pose,
    ) -> Self {
        PlannerTask {
            nav,
            host,
            mount,
            step_times: std::array::from_fn(|_| Histogram::new()),
            step_cpu_times: std::array::from_fn(|_| Histogram::new()),
            step_units,
            step_units_run: [0; STEP_PHASES.len()],
        }
    }

    /// The planner of `cfg`: the navigator over the configured (or
    /// generated) primitives, exploring with the internal simulation and
    /// its worker when configured; one that never plans when `on` is false.
    pub fn from_config(cfg: &Config, on: bool) -> Result<Self, String> {
        let res = cfg.maps.mls_resolution_m;
        let prims = if cfg.planner.mprim.is_empty() {
            primitives::generate(&primitives::PrimitiveSpec {
                resolution_m: res,
                ..Default::default()
            })
        } else {
            let path = &cfg.planner.mprim;
            let text =
                std::fs::read_to_string(path).map_err(|e| format!("cannot read {path}: {e}"))?;
            speleo_planner::mprim::parse(&text).map_err(|e| format!("{path}: {e}"))?
        };
        let (pc, route) = if on {
            (cfg.planner.clone(), &cfg.control.path[..])
        } else {
            let mut idle = cfg.planner.clone();
            idle.nav.trav.max_nodes = 16;
            idle.nav.window_m = 2.0;
            idle.nav.window_max_m = 2.0;
            idle.nav.goal_ahead_m = 1.0;
            (idle, &[][..])
        };
        let mut nav = Navigator::new(
            &pc.navigator_params(),
            &prims,
            res,
            route,
            cfg.control.looped,
            params::base_height_m(cfg),
        )?;
        let mut host = SimulatorHost::default();
        if on && cfg.exploration.enabled {
            nav = nav.with_exploration(exploration(cfg, &mut host)?);
        }
        Ok(PlannerTask::new(
            nav,
            pc.step_units.as_array(),
            host,
            params::mount_pose(cfg),
        ))
    }
}

/// The exploration `[exploration]` describes, every plan first driven in
/// the internal simulation (hosted on its worker core by `host`) when
/// `[simulator]` is on.
fn exploration(cfg: &Config, host: &mut SimulatorHost) -> Result<Exploration, String> {
    let e = &cfg.exploration;
    let mut ex = Exploration::new(
        e.explorer_params(),
        e.candidate_params(),
        e.target,
        e.settle_s,
    );
    if cfg.simulator.enabled {
        ex = ex.with_simulator(InternalSim::new(params::simulator(cfg))?);
        if cfg.simulator.worker_units > 0 {
            let w = SimulatorWorker::spawn(
                cfg.simulator.worker_units,
                cfg.simulator.params.dt_s,
                slot(),
            )
            .map_err(|e| format!("the simulator's worker: {e}"))?;
            host.worker = Some(w);
        }
        if let Some(dir) = &cfg.simulator.dump_dir {
            host.dump = Some(ValidationDump::new(dir)?);
        }
    }
    Ok(ex)
}

/// The planner task's accounting slot (the executive's numbering).
fn slot() -> u16 {
    let i = super::TASKS
        .iter()
        .position(|t| *t == "planner")
        .unwrap_or(0);
    1 + i as u16
}

impl Task<Bus> for PlannerTask {
    fn run(&mut self, _bus: &mut Bus, _cx: &Context) {}

    fn step(&mut self, bus: &mut Bus, cx: &Context, quantum: u32) -> StepResult {
        let timed = self.nav.timed_phase();
        let units = match timed {
            Some(i) => {
                let u = self.step_units[i].min(quantum).max(1);
                self.step_units_run[i] = u;
                u
            }
            None => quantum.max(1),
        };
        let lattice = self.nav.lattice_stage();
        let clouds = MapClouds {
            clouds: &bus.keyframe_clouds,
            mount: &self.mount,
        };
        let drives = bus.drives.get().map(|d| Stamped {
            stamp_ns: d.stamp_ns,
            seq: d.seq,
            value: DriveFeedback::from(&d.value),
        });
        let input = NavInput {
            now_ns: cx.time_ns,
            slam: bus.slam.get(),
            command: bus.command.get(),
            drives,
            map: bus.surface.serving(),
            clouds: &clouds,
        };
        let started = std::time::Instant::now();
        let cpu0 = thread_cpu_ns();
        let more = self.nav.step(&input, units, &mut self.host);
        if let Some(i) = timed {
            let wall_ns = started.elapsed().as_nanos() as u64;
            let cpu_ns = thread_cpu_ns().saturating_sub(cpu0);
            self.step_times[i].record(wall_ns);
            self.step_cpu_times[i].record(cpu_ns);
            if cpu_ns > SLOW_STEP_NS {
                // Which phase, and whether the step ended it: what a
                // calibration by units cannot see.
                let next = self.nav.timed_phase().map(|j| STEP_PHASES[j]);
                tracing::debug!(phase = STEP_PHASES[i], lattice, units, cpu_us = cpu_ns / 1000, wall_us = wall_ns / 1000, next = ?next, "slow planner step");
            }
        }
        let now = cx.time_ns;
        self.nav.take_plans(|p| bus.plan.publish(now, p.clone()));
        bus.exploration = self.nav.status();
        if more {
            StepResult::Continue
        } else {
            StepResult::Idle
        }
    }
}
