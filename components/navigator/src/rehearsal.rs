//! Where the internal simulation runs besides the navigator's own step, and
//! what is kept of each validation: the flight software lends the
//! simulator to a worker core and may write every validation's inputs to
//! files; the navigator only sees this trait.

use std::cell::RefCell;

use speleo_simulator::{InternalSim, Stance, ValidationCase, Verdict};

/// The simulator's host: a worker it is lent to, and a record of the
/// validations. The defaults are neither (everything in the step).
pub trait Rehearsal {
    /// Whether the simulator's batches run on a worker (all but the clouds'
    /// integration).
    fn offloads(&self) -> bool {
        false
    }

    /// The simulator back from its batch, waiting for it; `None` when none
    /// is out.
    fn join(&mut self) -> Option<Box<InternalSim>> {
        None
    }

    /// Lend `sim` for a batch; it is handed back when it cannot be.
    fn lend(&mut self, sim: Box<InternalSim>) -> Result<(), Box<InternalSim>> {
        Err(sim)
    }

    /// The record of validations, when one is kept.
    fn record(&mut self) -> Option<&mut dyn ValidationRecord> {
        None
    }
}

/// Each validation's inputs and verdict, kept away from the mission.
pub trait ValidationRecord {
    /// A validation begins at `now_ns` from `start` along `plan`.
    fn begin(
        &mut self,
        now_ns: u64,
        start: Stance,
        way_back: bool,
        plan: &mut dyn Iterator<Item = [f64; 4]>,
    );
    /// The case under way, filled as the simulator reads the clouds.
    fn case(&self) -> &RefCell<ValidationCase>;
    /// The verdict of validation `index` (the mission's count, from 1).
    fn finish(&mut self, index: u64, verdict: Verdict);
}

/// No worker and no record: the simulation runs in the navigator's steps.
#[derive(Clone, Copy, Debug, Default)]
pub struct InStep;

impl Rehearsal for InStep {}
