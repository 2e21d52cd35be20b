//! The planner task: the navigator (`speleo_navigator`) as an anytime
//! task. Each step reads the mailboxes, has the navigator do one phase's
//! work for that phase's units (`planner.step_units`, at most the
//! scheduler's quantum), publishes the plans it made and the exploration's
//! state, and times the step for the units' calibration.

use speleo_messages::DriveFeedback;
use speleo_navigator::{NavInput, Navigator, STEP_PHASES};
use speleo_scheduler::histogram::Histogram;
use speleo_scheduler::mailbox::Stamped;
use speleo_scheduler::realtime::thread_cpu_ns;
use speleo_scheduler::{Context, StepResult, Task};
use speleo_slam::lie::Pose;

use crate::bus::Bus;
use crate::sim_clouds::MapClouds;
use crate::sim_host::SimHost;

/// A step this long on the thread's CPU clock is logged (debug), ns.
const SLOW_STEP_NS: u64 = 1_000_000;

pub struct PlannerTask {
    pub nav: Navigator,
    /// The internal simulator's worker and the validations' record.
    pub host: SimHost,
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
        host: SimHost,
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
