//! What the navigator reads each step, and what it hands back: the plans it
//! published and the exploration's state.

use speleo_mapping::mls::MlsMap;
use speleo_messages::{DriveFeedback, ExplorationStatus, PlanMsg, SlamPose, WheelCommand};
use speleo_scheduler::mailbox::Stamped;
use speleo_simulator::CloudSource;

/// One step's inputs, as the mailboxes hold them at the step's frame.
pub struct NavInput<'a> {
    /// The frame's time, ns since start.
    pub now_ns: u64,
    /// The newest SLAM pose.
    pub slam: Option<&'a Stamped<SlamPose>>,
    /// The control task's newest wheel command: which plan it follows,
    /// whether it is done, and why it stopped.
    pub command: Option<&'a Stamped<WheelCommand>>,
    /// The drives' newest feedback, for the energy meter.
    pub drives: Option<Stamped<DriveFeedback>>,
    /// The serving multi-level surface map.
    pub map: &'a MlsMap,
    /// The keyframe clouds in the map frame: the internal simulation's
    /// world.
    pub clouds: &'a dyn CloudSource,
}

/// The keyframe clouds as the internal simulator takes them.
pub(crate) struct Clouds<'a>(pub &'a dyn CloudSource);

impl CloudSource for Clouds<'_> {
    fn keyframes(&self) -> usize {
        self.0.keyframes()
    }

    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        self.0.origin(k)
    }

    fn points(&self, k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        self.0.points(k, from, n, out)
    }

    fn intensities(&self, k: usize, from: usize, n: usize, out: &mut Vec<u8>) {
        self.0.intensities(k, from, n, out);
    }
}

/// Plans published in one step at most (a plan, then the same marked to
/// be driven, is the most a step does).
const PLANS_PER_STEP: usize = 4;

/// The plans a step published, in order, the last one shown (what the
/// bus's plan mailbox holds), and the exploration's state.
pub struct Outbox {
    plans: heapless::Vec<PlanMsg, PLANS_PER_STEP>,
    shown: Option<PlanMsg>,
    pub status: ExplorationStatus,
}

impl Default for Outbox {
    fn default() -> Self {
        Self::new()
    }
}

impl Outbox {
    pub fn new() -> Self {
        Outbox {
            plans: heapless::Vec::new(),
            shown: None,
            status: ExplorationStatus::default(),
        }
    }

    /// A step begins: the last step's plans were handed over.
    pub(crate) fn begin_step(&mut self) {
        self.plans.clear();
    }

    /// Publish `msg`: it is shown from now on and handed over after the
    /// step. Past [`PLANS_PER_STEP`] in one step the oldest unsent one is
    /// dropped (a consumer reads only the newest).
    pub fn publish(&mut self, msg: PlanMsg) {
        if self.plans.is_full() {
            self.plans.remove(0);
        }
        let _ = self.plans.push(msg.clone());
        self.shown = Some(msg);
    }

    /// The plan published last.
    pub fn shown(&self) -> Option<&PlanMsg> {
        self.shown.as_ref()
    }

    /// Each plan published since the step began, oldest first; then none.
    pub fn drain(&mut self, mut f: impl FnMut(&PlanMsg)) {
        for p in &self.plans {
            f(p);
        }
        self.plans.clear();
    }
}
