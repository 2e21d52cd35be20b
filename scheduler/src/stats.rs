//! Per-task execution statistics, measured with the monotonic clock (and
//! the thread's CPU clock where the platform has one).

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
    /// The runs' CPU time (empty where the platform cannot measure it): the
    /// wall time less the time the thread was preempted.
    pub cpu_histogram: Histogram,
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
    /// The CPU time's p99, p99.9 and max, µs, when it was measured.
    pub fn cpu_us(&self) -> Option<CpuFigures> {
        let h = &self.cpu_histogram;
        (h.count() > 0).then(|| CpuFigures {
            p99_us: h.quantile_ns(0.99) as f64 / 1000.0,
            p999_us: h.quantile_ns(0.999) as f64 / 1000.0,
            max_us: h.max_ns() as f64 / 1000.0,
        })
    }
}

/// A task's runs measured on its thread's CPU clock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpuFigures {
    pub p99_us: f64,
    pub p999_us: f64,
    pub max_us: f64,
}
