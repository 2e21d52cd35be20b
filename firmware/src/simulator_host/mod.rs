//! The internal simulation's host on the rover: the worker core it is lent
//! to between frames and the record of its validations (`[simulator]
//! worker_units`, `dump_dir`), as the navigator's [`Rehearsal`].

use speleo_navigator::{Rehearsal, ValidationRecord};
use speleo_simulator::InternalSim;

mod worker;

use crate::validation_dump::ValidationDump;
pub use worker::{SimulatorWorker, WorkerCounters, SIM_WORKER_BUDGET_US};

#[derive(Default)]
pub struct SimulatorHost {
    /// The core of its own the simulator does most of its work on.
    pub worker: Option<SimulatorWorker>,
    /// Every validation's inputs written to files.
    pub dump: Option<ValidationDump>,
}

impl Rehearsal for SimulatorHost {
    fn offloads(&self) -> bool {
        self.worker.is_some()
    }

    fn join(&mut self) -> Option<Box<InternalSim>> {
        self.worker.as_mut().and_then(SimulatorWorker::join)
    }

    fn lend(&mut self, sim: Box<InternalSim>) -> Result<(), Box<InternalSim>> {
        match self.worker.as_mut() {
            Some(w) => w.lend(sim),
            None => Err(sim),
        }
    }

    fn record(&mut self) -> Option<&mut dyn ValidationRecord> {
        self.dump.as_mut().map(|d| d as &mut dyn ValidationRecord)
    }
}
