//! The task protocol: what the executive calls and what a task is told.

/// Which schedule the executive is running.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Nominal,
    /// Only tasks marked `in_safe_mode` run; motor outputs command zero.
    Safe,
}

/// What a task is told about the frame it runs in.
#[derive(Clone, Copy, Debug)]
pub struct Context {
    /// Minor frame number since start.
    pub frame: u64,
    /// Start time of the frame in nanoseconds since the executive started
    /// (virtual on the virtual clock).
    pub time_ns: u64,
    pub minor_frame_ns: u64,
    pub mode: Mode,
    /// The task has been told to run in its reduced mode.
    pub degraded: bool,
}

/// What one anytime step reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepResult {
    /// More work is pending; call again if the run has steps left.
    Continue,
    /// Nothing left to do this run (converged, queue empty, plan found).
    Idle,
}

/// A task scheduled by the executive. `B` is the mailbox bus, owned by the
/// application and handed to every task in turn.
///
/// A periodic task does its work in [`Task::run`]. An anytime task uses `run`
/// to take its inputs at the start of its window and then does one fixed
/// quantum of work per [`Task::step`].
pub trait Task<B> {
    fn run(&mut self, bus: &mut B, cx: &Context);

    /// One quantum of anytime work (`quantum` units as declared in the schedule).
    fn step(&mut self, _bus: &mut B, _cx: &Context, _quantum: u32) -> StepResult {
        StepResult::Idle
    }

    /// Enter (`true`) or leave the task's own reduced mode (degrade policy).
    fn set_degraded(&mut self, _degraded: bool) {}

    /// Withdraw the output of the run that just overran (reuse-last policy):
    /// roll back the mailboxes the task published to, so consumers keep the
    /// previous value with its old timestamp.
    fn retract(&mut self, _bus: &mut B) {}

    /// The task does not run in a frame it is due in (skip policy, or the
    /// safe schedule leaves it out): withdraw what its last run left for
    /// the frame, when that is per-frame data others would take as new.
    fn skipped(&mut self, _bus: &mut B) {}
}
