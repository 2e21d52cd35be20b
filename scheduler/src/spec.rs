//! What a task declares about itself: rate group, budget, overrun policy and,
//! for anytime tasks, the work quantum and window.

use core::fmt;

/// A task's name: fixed capacity so schedules need no heap.
pub type TaskName = heapless::String<32>;

/// Which minor frames a task runs in: frame `f` when `f % divisor == offset`.
///
/// Divisor 10, offset 3 runs in frames 3, 13, 23, ...
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RateGroup {
    pub divisor: u32,
    pub offset: u32,
}

impl RateGroup {
    /// Every frame.
    pub const EVERY_FRAME: RateGroup = RateGroup {
        divisor: 1,
        offset: 0,
    };

    pub const fn new(divisor: u32, offset: u32) -> Self {
        RateGroup { divisor, offset }
    }

    /// Does the group run in minor frame `frame`?
    #[inline]
    pub fn runs_in(&self, frame: u64) -> bool {
        frame % self.divisor as u64 == self.offset as u64
    }

    /// Period in microseconds for a given minor frame length.
    pub fn period_us(&self, minor_frame_us: u32) -> u64 {
        self.divisor as u64 * minor_frame_us as u64
    }
}

/// What the executive does when a task's run takes longer than its budget.
///
/// Policies act on measured wall time, so on the virtual clock they are only
/// applied when the executive is told to enforce them (see
/// [`crate::Enforcement`]); overruns are always counted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OverrunPolicy {
    /// Skip the task's next scheduled run to give the time back.
    Skip,
    /// Withdraw the late output: the task's mailboxes are rolled back, so
    /// consumers keep the previous output and see its old timestamp.
    ReuseLast,
    /// Tell the task to switch to its own reduced mode until it has run within
    /// budget for [`DEGRADE_RECOVERY_RUNS`] runs in a row.
    Degrade,
    /// Switch the whole executive to the safe schedule: motors commanded to
    /// zero, sensors still decoded and recorded.
    SafeMode,
}

/// Clean runs in a row after which a degraded task is restored.
pub const DEGRADE_RECOVERY_RUNS: u32 = 100;

impl OverrunPolicy {
    /// The configuration spelling.
    pub fn as_str(&self) -> &'static str {
        match self {
            OverrunPolicy::Skip => "skip",
            OverrunPolicy::ReuseLast => "reuse-last",
            OverrunPolicy::Degrade => "degrade",
            OverrunPolicy::SafeMode => "safe-mode",
        }
    }

    /// Parse the configuration spelling.
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "skip" => OverrunPolicy::Skip,
            "reuse-last" => OverrunPolicy::ReuseLast,
            "degrade" => OverrunPolicy::Degrade,
            "safe-mode" => OverrunPolicy::SafeMode,
            _ => return None,
        })
    }
}

impl fmt::Display for OverrunPolicy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The extra declaration of an anytime task.
///
/// Each run the executive calls `step` at most `steps` times; each step does
/// `quantum` units of the task's own work (expansions, physics ticks, solver
/// iterations). The amount of work per run is therefore fixed, and the output
/// never depends on machine speed. `window_us` is the share of the frame the
/// task may use; exceeding it counts as an overrun, it does not stop the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AnytimeSpec {
    pub quantum: u32,
    pub steps: u32,
    pub window_us: u32,
}

/// Everything the executive needs to know about one task.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TaskSpec {
    pub name: TaskName,
    pub rate: RateGroup,
    /// Time budget of one run (for an anytime task: of one step).
    pub budget_us: u32,
    pub policy: OverrunPolicy,
    pub anytime: Option<AnytimeSpec>,
    /// Runs in the safe schedule too (drivers, motor output, health, recorder).
    pub in_safe_mode: bool,
}

impl TaskSpec {
    /// A periodic task. Names longer than 32 bytes are cut at a char boundary.
    pub fn periodic(name: &str, rate: RateGroup, budget_us: u32, policy: OverrunPolicy) -> Self {
        TaskSpec {
            name: short_name(name),
            rate,
            budget_us,
            policy,
            anytime: None,
            in_safe_mode: false,
        }
    }

    /// An anytime task: `steps` steps of `quantum` work units within `window_us`.
    pub fn anytime(
        name: &str,
        rate: RateGroup,
        step_budget_us: u32,
        policy: OverrunPolicy,
        anytime: AnytimeSpec,
    ) -> Self {
        TaskSpec {
            anytime: Some(anytime),
            ..TaskSpec::periodic(name, rate, step_budget_us, policy)
        }
    }

    /// Mark the task as part of the safe schedule.
    pub fn safe(mut self) -> Self {
        self.in_safe_mode = true;
        self
    }

    /// Time the task may occupy in a frame it runs in.
    pub fn frame_share_us(&self) -> u32 {
        match self.anytime {
            Some(a) => a.window_us,
            None => self.budget_us,
        }
    }

    /// Time budget of one whole run, the threshold for an overrun.
    pub fn run_budget_us(&self) -> u32 {
        self.frame_share_us()
    }
}

fn short_name(name: &str) -> TaskName {
    let mut out = TaskName::new();
    for c in name.chars() {
        if out.push(c).is_err() {
            break;
        }
    }
    out
}
