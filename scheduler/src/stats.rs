//! Per-task execution statistics, measured with the monotonic clock.

use crate::histogram::Histogram;

#[derive(Clone, Debug, Default)]
pub struct TaskStats {
    /// Runs the task was called for (an anytime run counts once).
    pub runs: u64,
    /// Runs longer than the task's run budget (or window).
    pub overruns: u64,
    /// Scheduled runs left out by the skip policy or the safe schedule.
    pub skipped: u64,
    /// Anytime steps taken.
    pub steps: u64,
    /// Overruns whose output was withdrawn (reuse-last policy).
    pub retracted: u64,
    /// Is the task in its degraded mode now?
    pub degraded: bool,
    /// Most heap bytes requested within one run.
    pub alloc_bytes_max_run: u64,
    pub(crate) clean_runs: u32,
    pub(crate) skip_next: bool,
    pub histogram: Histogram,
}

impl TaskStats {
    pub fn max_us(&self) -> f64 {
        self.histogram.max_ns() as f64 / 1000.0
    }
    pub fn p50_us(&self) -> f64 {
        self.histogram.quantile_ns(0.5) as f64 / 1000.0
    }
    pub fn p99_us(&self) -> f64 {
        self.histogram.quantile_ns(0.99) as f64 / 1000.0
    }
    pub fn p999_us(&self) -> f64 {
        self.histogram.quantile_ns(0.999) as f64 / 1000.0
    }
}
