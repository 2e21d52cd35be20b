//! The cyclic executive: runs the tasks of each minor frame in table order,
//! measures them, and applies overrun policies.

use crate::clock::{FrameClock, Platform, EXECUTIVE_SLOT};
use crate::events::{EventLog, OverrunEvent};
use crate::schedule::Schedule;
use crate::spec::{OverrunPolicy, DEGRADE_RECOVERY_RUNS};
use crate::stats::TaskStats;
use crate::task::{Context, Mode, StepResult, Task};
use crate::MAX_TASKS;

/// Whether measured overruns change what runs.
///
/// Overruns depend on wall time. On the virtual clock (sim, replay) policies
/// are normally only counted, so that outputs stay bit-identical on any
/// machine; the real rover and budget tests enforce them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Enforcement {
    Enforce,
    CountOnly,
    /// Replay of an enforcing run: the overruns are not measured but taken
    /// from the run's record ([`Executive::replay_overruns`]) and enforced
    /// as they were, so the replay takes the run's decisions.
    Replay,
}

impl Enforcement {
    /// Whether overrun policies change what runs.
    pub fn enforces(self) -> bool {
        matches!(self, Enforcement::Enforce | Enforcement::Replay)
    }
}

/// What happened in one frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameReport {
    pub frame: u64,
    pub time_ns: u64,
    /// Frames the clock slipped past before this one.
    pub slipped: u64,
    pub tasks_run: u32,
    pub overruns: u32,
    /// Bit `i`: task `i` of the schedule overran its budget.
    pub overran: u64,
}

/// Error building an executive.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ExecutiveError {
    /// The number of task objects differs from the schedule's table.
    TaskCountMismatch { schedule: usize, tasks: usize },
}

impl core::fmt::Display for ExecutiveError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ExecutiveError::TaskCountMismatch { schedule, tasks } => write!(
                f,
                "the schedule lists {schedule} tasks but {tasks} task objects were given"
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for ExecutiveError {}

pub struct Executive<'t, B, P: Platform, C: FrameClock> {
    schedule: Schedule,
    tasks: heapless::Vec<&'t mut dyn Task<B>, MAX_TASKS>,
    stats: heapless::Vec<TaskStats, MAX_TASKS>,
    platform: P,
    clock: C,
    enforcement: Enforcement,
    next_frame: u64,
    frames_run: u64,
    slips: u64,
    started: bool,
    mode: Mode,
    safe_cause: Option<usize>,
    events: EventLog,
    /// The overruns of the next frame, in replay.
    replayed_overruns: u64,
}

impl<'t, B, P: Platform, C: FrameClock> Executive<'t, B, P, C> {
    /// `tasks` are in the order of `schedule.tasks()`; that order is also the
    /// order of execution within a frame.
    pub fn new(
        schedule: Schedule,
        tasks: heapless::Vec<&'t mut dyn Task<B>, MAX_TASKS>,
        platform: P,
        clock: C,
        enforcement: Enforcement,
    ) -> Result<Self, ExecutiveError> {
        if tasks.len() != schedule.tasks().len() {
            return Err(ExecutiveError::TaskCountMismatch {
                schedule: schedule.tasks().len(),
                tasks: tasks.len(),
            });
        }
        let mut stats = heapless::Vec::new();
        for _ in 0..tasks.len() {
            let _ = stats.push(TaskStats::default());
        }
        // At most 10 logged overruns per second of frames.
        let window = (1_000_000 / schedule.minor_frame_us().max(1)) as u64;
        Ok(Executive {
            schedule,
            tasks,
            stats,
            platform,
            clock,
            enforcement,
            next_frame: 0,
            frames_run: 0,
            slips: 0,
            started: false,
            mode: Mode::Nominal,
            safe_cause: None,
            events: EventLog::new(window, 10),
            replayed_overruns: 0,
        })
    }

    /// In replay ([`Enforcement::Replay`]): the tasks that overran in the
    /// recorded frame about to run (bit `i`: task `i`).
    pub fn replay_overruns(&mut self, overran: u64) {
        self.replayed_overruns = overran;
    }

    /// Run one minor frame: wait for it, then run every task due in it.
    pub fn run_frame(&mut self, bus: &mut B) -> FrameReport {
        self.run_frame_with(bus, &mut |_| {})
    }

    /// [`Executive::run_frame`], calling `between(i)` after task `i` has
    /// run. The time `between` takes is charged to no task: it is for the
    /// outside world (a simulated rover moving on while the tasks run),
    /// not for on-board work.
    pub fn run_frame_with(&mut self, bus: &mut B, between: &mut dyn FnMut(usize)) -> FrameReport {
        if !self.started {
            self.clock.start();
            self.started = true;
        }
        let frame = self.clock.wait_frame(self.next_frame);
        let slipped = frame.saturating_sub(self.next_frame);
        self.slips += slipped;
        let mut cx = Context {
            frame,
            time_ns: self.clock.frame_time_ns(frame),
            minor_frame_ns: self.clock.minor_frame_ns(),
            mode: self.mode,
            degraded: false,
        };
        let mut tasks_run = 0;
        let mut overruns = 0;
        let mut overran = 0u64;
        let replayed = core::mem::take(&mut self.replayed_overruns);
        // The clock is read again after the bookkeeping of each run, so a
        // task is charged for its own run and nothing else.
        let mut t0 = self.platform.now_ns();
        let mut c0 = self.platform.thread_cpu_ns();
        for i in 0..self.tasks.len() {
            let spec = &self.schedule.tasks()[i];
            if !spec.rate.runs_in(frame) {
                continue;
            }
            let st = &mut self.stats[i];
            if (cx.mode == Mode::Safe && !spec.in_safe_mode) || st.skip_next {
                st.skip_next = false;
                st.skipped += 1;
                self.tasks[i].skipped(bus);
                continue;
            }
            cx.degraded = st.degraded;
            let task = &mut *self.tasks[i];
            let slot = 1 + i as u16;
            let bytes0 = self.platform.allocated_bytes(slot);
            self.platform.enter(slot);
            task.run(bus, &cx);
            if let Some(any) = spec.anytime {
                for _ in 0..any.steps {
                    st.steps += 1;
                    if task.step(bus, &cx, any.quantum) == StepResult::Idle {
                        break;
                    }
                }
            }
            let t1 = self.platform.now_ns();
            let c1 = self.platform.thread_cpu_ns();
            let dt = t1.saturating_sub(t0);
            if let (Some(c0), Some(c1)) = (c0, c1) {
                st.cpu_histogram.record(c1.saturating_sub(c0));
            }
            self.platform.enter(EXECUTIVE_SLOT);
            let run_bytes = self.platform.allocated_bytes(slot).saturating_sub(bytes0);
            st.alloc_bytes_max_run = st.alloc_bytes_max_run.max(run_bytes);
            tasks_run += 1;
            st.runs += 1;
            st.histogram.record(dt);
            let budget_ns = spec.run_budget_us() as u64 * 1000;
            let over = match self.enforcement {
                Enforcement::Replay => replayed & (1 << i) != 0,
                _ => dt > budget_ns,
            };
            if over {
                overruns += 1;
                overran |= 1 << i;
                st.overruns += 1;
                st.clean_runs = 0;
                let enforced = self.enforcement.enforces();
                self.events.push(OverrunEvent {
                    task: spec.name.clone(),
                    frame,
                    duration_ns: dt,
                    budget_ns,
                    enforced,
                });
                if enforced {
                    match spec.policy {
                        OverrunPolicy::Skip => st.skip_next = true,
                        OverrunPolicy::ReuseLast => {
                            task.retract(bus);
                            st.retracted += 1;
                        }
                        OverrunPolicy::Degrade => {
                            if !st.degraded {
                                st.degraded = true;
                                task.set_degraded(true);
                            }
                        }
                        OverrunPolicy::SafeMode => {
                            if self.mode != Mode::Safe {
                                self.mode = Mode::Safe;
                                self.safe_cause = Some(i);
                                // Later tasks of this frame already see it, so
                                // the motor output commands zero in this frame.
                                cx.mode = Mode::Safe;
                            }
                        }
                    }
                }
            } else if st.degraded {
                st.clean_runs += 1;
                if st.clean_runs >= DEGRADE_RECOVERY_RUNS {
                    st.degraded = false;
                    st.clean_runs = 0;
                    task.set_degraded(false);
                }
            }
            between(i);
            t0 = self.platform.now_ns();
            c0 = self.platform.thread_cpu_ns();
        }
        self.next_frame = frame + 1;
        self.frames_run += 1;
        FrameReport {
            frame,
            time_ns: cx.time_ns,
            slipped,
            tasks_run,
            overruns,
            overran,
        }
    }

    /// Switch to the safe schedule (e.g. on a health fault). It stays until
    /// [`Executive::leave_safe_mode`].
    pub fn enter_safe_mode(&mut self) {
        self.mode = Mode::Safe;
    }

    pub fn leave_safe_mode(&mut self) {
        self.mode = Mode::Nominal;
        self.safe_cause = None;
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The task whose overrun switched to safe mode, if that was the cause.
    pub fn safe_mode_cause(&self) -> Option<&str> {
        self.safe_cause
            .map(|i| self.schedule.tasks()[i].name.as_str())
    }

    pub fn schedule(&self) -> &Schedule {
        &self.schedule
    }

    pub fn stats(&self) -> &[TaskStats] {
        &self.stats
    }

    /// Frames executed so far.
    pub fn frames_run(&self) -> u64 {
        self.frames_run
    }

    /// The next frame number due.
    pub fn next_frame(&self) -> u64 {
        self.next_frame
    }

    /// Frames lost because the work of a frame ran past the next frame's start.
    pub fn slips(&self) -> u64 {
        self.slips
    }

    /// Logged overrun events, oldest first.
    pub fn pop_event(&mut self) -> Option<OverrunEvent> {
        self.events.pop()
    }

    pub fn suppressed_events(&self) -> u64 {
        self.events.suppressed()
    }

    pub fn platform(&self) -> &P {
        &self.platform
    }

    pub fn clock(&self) -> &C {
        &self.clock
    }
}
