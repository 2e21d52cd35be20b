//! The internal simulator on a core of its own: the planner task lends it
//! the validation under way for one batch of `[simulator] worker_units`
//! units a frame and takes it back in its next run (see
//! [`speleo_scheduler::coprocessor`]). Only the TSDF integration of the
//! keyframe clouds, which the worker cannot read while the other tasks
//! write them, stays in the planner's own window.
//!
//! 120 units a frame are 20 physics steps of 10 ms: the simulated rover
//! drives 20 times faster than real time, as the paper asks, and the
//! verdict comes at the same frame on any machine.

use speleo_scheduler::accounting;
use speleo_scheduler::coprocessor::{Coprocessor, FrameSync};
use speleo_scheduler::histogram::Histogram;
use speleo_simulator::InternalSim;

/// The internal simulator's batch on its worker core
/// (`[simulator] worker_units`): it has the frame, less the hand-overs.
pub const SIM_WORKER_BUDGET_US: u32 = 8_000;

/// What the worker did, for the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WorkerCounters {
    pub batches: u64,
    /// Batches whose wall time was over the worker's budget
    /// ([`SIM_WORKER_BUDGET_US`]), as the
    /// executive counts its tasks' overruns.
    pub overruns: u64,
    /// Batches that drove the simulated rover, and its physics steps in them.
    pub drive_batches: u64,
    pub drive_steps: u64,
}

pub struct SimulatorWorker {
    cp: Coprocessor<InternalSim>,
    units: u32,
    /// The simulator's physics step, s.
    dt_s: f64,
    /// The work the batch out began in, and the physics steps before it.
    out: Option<(&'static str, u64, u64)>,
    /// Wall time of each batch on the worker, and its CPU time.
    pub batch_times: Histogram,
    pub batch_cpu_times: Histogram,
    pub counters: WorkerCounters,
}

fn batch(sim: &mut InternalSim, units: u32) {
    let _ = sim.step_without_clouds(units as usize);
}

impl SimulatorWorker {
    /// Start the worker thread; its allocations are counted as `slot`'s.
    pub fn spawn(units: u32, dt_s: f64, slot: u16) -> std::io::Result<Self> {
        Ok(SimulatorWorker {
            cp: Coprocessor::spawn("speleo-sim", slot, batch)?,
            units,
            dt_s,
            out: None,
            batch_times: Histogram::new(),
            batch_cpu_times: Histogram::new(),
            counters: WorkerCounters::default(),
        })
    }

    /// The handle the frame loop waits on before each frame.
    pub fn sync(&self) -> FrameSync {
        self.cp.sync()
    }

    pub fn is_lent(&self) -> bool {
        self.cp.is_lent()
    }

    /// Lend `sim` for a batch, unless its next step reads the clouds:
    /// then it is given back.
    pub fn lend(&mut self, sim: Box<InternalSim>) -> Result<(), Box<InternalSim>> {
        if sim.needs_clouds() {
            return Err(sim);
        }
        let work = sim.work();
        let (steps, load) = (sim.counters.physics_steps, sim.counters.contact_load);
        self.cp.lend(sim, self.units)?;
        self.out = Some((work, steps, load));
        Ok(())
    }

    /// How much faster than real time the simulated rover drove: the
    /// simulated time of the batches that drove it over their frames
    /// (a batch a frame of `minor_frame_us`).
    pub fn speed_x_real_time(&self, minor_frame_us: u32) -> Option<f64> {
        let c = &self.counters;
        (c.drive_batches > 0).then(|| {
            c.drive_steps as f64 * self.dt_s
                / (c.drive_batches as f64 * minor_frame_us as f64 * 1e-6)
        })
    }

    /// The simulator back from its batch (waiting for it), the batch's
    /// allocations charged to the running task.
    pub fn join(&mut self) -> Option<Box<InternalSim>> {
        let (sim, b) = self.cp.join()?;
        accounting::charge(b.allocations, b.bytes);
        self.batch_times.record(b.elapsed_ns);
        self.batch_cpu_times.record(b.cpu_ns);
        self.counters.batches += 1;
        let budget_ns = SIM_WORKER_BUDGET_US as u64 * 1000;
        if b.elapsed_ns > budget_ns {
            self.counters.overruns += 1;
        }
        if let Some((work, steps, load)) = self.out.take() {
            let steps = sim.counters.physics_steps - steps;
            let load = sim.counters.contact_load - load;
            if work == "drive" {
                self.counters.drive_batches += 1;
                self.counters.drive_steps += steps;
            }
            tracing::trace!(
                work,
                steps,
                load,
                cpu_us = b.cpu_ns / 1000,
                wall_us = b.elapsed_ns / 1000,
                "simulator batch"
            );
            if b.cpu_ns > budget_ns {
                // Which work, and how far it got: what the units missed.
                tracing::debug!(
                    work,
                    next = sim.work(),
                    steps,
                    load,
                    units = self.units,
                    cpu_us = b.cpu_ns / 1000,
                    wall_us = b.elapsed_ns / 1000,
                    "slow simulator batch"
                );
            }
        }
        Some(sim)
    }
}
