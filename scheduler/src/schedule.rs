//! Building a schedule and proving that it fits before anything runs.

use core::fmt;

use crate::spec::TaskSpec;
use crate::MAX_TASKS;

/// Longest hyperperiod (least common multiple of the divisors), in frames, that
/// is checked frame by frame. Longer ones are refused: they are almost always a
/// configuration mistake and would make the check slow.
pub const MAX_HYPERPERIOD: u64 = 1_000_000;

/// A checked, immutable schedule.
#[derive(Clone, Debug)]
pub struct Schedule {
    minor_frame_us: u32,
    margin_us: u32,
    hyperperiod: u64,
    tasks: heapless::Vec<TaskSpec, MAX_TASKS>,
}

/// Why a schedule was refused.
///
/// `Overbooked` carries the frame's task list inline (about 1 KiB) because
/// the core has no heap; the error is built once, when a schedule is loaded.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ScheduleError {
    ZeroMinorFrame,
    TooManyTasks {
        max: usize,
    },
    DuplicateName {
        name: crate::TaskName,
    },
    BadRateGroup {
        task: crate::TaskName,
        divisor: u32,
        offset: u32,
    },
    ZeroBudget {
        task: crate::TaskName,
    },
    BadAnytime {
        task: crate::TaskName,
        reason: &'static str,
    },
    HyperperiodTooLong {
        frames: u64,
    },
    /// The budgets of the tasks that run in `frame` plus the margin exceed the
    /// minor frame.
    Overbooked {
        frame: u64,
        needed_us: u64,
        minor_frame_us: u32,
        margin_us: u32,
        /// The tasks of that frame with their shares, largest first.
        tasks: heapless::Vec<(crate::TaskName, u32), MAX_TASKS>,
    },
}

impl fmt::Display for ScheduleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScheduleError::ZeroMinorFrame => write!(f, "the minor frame must be longer than 0 us"),
            ScheduleError::TooManyTasks { max } => {
                write!(f, "a schedule holds at most {max} tasks")
            }
            ScheduleError::DuplicateName { name } => {
                write!(f, "two tasks are named `{name}`")
            }
            ScheduleError::BadRateGroup {
                task,
                divisor,
                offset,
            } => write!(
                f,
                "task `{task}`: rate group divisor {divisor} offset {offset} is invalid \
                 (the divisor must be at least 1 and the offset smaller than it)"
            ),
            ScheduleError::ZeroBudget { task } => {
                write!(f, "task `{task}`: the budget must be at least 1 us")
            }
            ScheduleError::BadAnytime { task, reason } => {
                write!(f, "anytime task `{task}`: {reason}")
            }
            ScheduleError::HyperperiodTooLong { frames } => write!(
                f,
                "the rate groups repeat only every {frames} frames (more than {MAX_HYPERPERIOD}); \
                 choose divisors with a smaller common multiple"
            ),
            ScheduleError::Overbooked {
                frame,
                needed_us,
                minor_frame_us,
                margin_us,
                tasks,
            } => {
                write!(
                    f,
                    "unschedulable: minor frame {frame} needs {needed_us} us but the frame is \
                     {minor_frame_us} us: "
                )?;
                for (name, us) in tasks {
                    write!(f, "{name} {us} us + ")?;
                }
                write!(f, "margin {margin_us} us")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for ScheduleError {}

impl Schedule {
    /// Check `tasks` against a minor frame and a safety margin.
    ///
    /// In every minor frame of the hyperperiod, the shares (budgets, or windows
    /// for anytime tasks) of the tasks that run in it plus `margin_us` must fit
    /// in `minor_frame_us`.
    #[allow(clippy::result_large_err)] // see ScheduleError
    pub fn build(
        minor_frame_us: u32,
        margin_us: u32,
        tasks: &[TaskSpec],
    ) -> Result<Schedule, ScheduleError> {
        if minor_frame_us == 0 {
            return Err(ScheduleError::ZeroMinorFrame);
        }
        if tasks.len() > MAX_TASKS {
            return Err(ScheduleError::TooManyTasks { max: MAX_TASKS });
        }
        let mut hyperperiod: u64 = 1;
        for (i, t) in tasks.iter().enumerate() {
            if tasks[..i].iter().any(|o| o.name == t.name) {
                return Err(ScheduleError::DuplicateName {
                    name: t.name.clone(),
                });
            }
            if t.rate.divisor == 0 || t.rate.offset >= t.rate.divisor {
                return Err(ScheduleError::BadRateGroup {
                    task: t.name.clone(),
                    divisor: t.rate.divisor,
                    offset: t.rate.offset,
                });
            }
            if t.budget_us == 0 {
                return Err(ScheduleError::ZeroBudget {
                    task: t.name.clone(),
                });
            }
            if let Some(a) = t.anytime {
                let reason = if a.steps == 0 {
                    Some("it must take at least one step per run")
                } else if a.quantum == 0 {
                    Some("its work quantum must be at least 1")
                } else if (a.steps as u64) * (t.budget_us as u64) > a.window_us as u64 {
                    Some("steps x step budget does not fit in its window")
                } else {
                    None
                };
                if let Some(reason) = reason {
                    return Err(ScheduleError::BadAnytime {
                        task: t.name.clone(),
                        reason,
                    });
                }
            }
            hyperperiod = lcm(hyperperiod, t.rate.divisor as u64);
            if hyperperiod > MAX_HYPERPERIOD {
                return Err(ScheduleError::HyperperiodTooLong {
                    frames: hyperperiod,
                });
            }
        }
        for frame in 0..hyperperiod {
            let needed: u64 = margin_us as u64
                + tasks
                    .iter()
                    .filter(|t| t.rate.runs_in(frame))
                    .map(|t| t.frame_share_us() as u64)
                    .sum::<u64>();
            if needed > minor_frame_us as u64 {
                let mut list: heapless::Vec<(crate::TaskName, u32), MAX_TASKS> =
                    heapless::Vec::new();
                for t in tasks.iter().filter(|t| t.rate.runs_in(frame)) {
                    // Capacity equals MAX_TASKS, checked above.
                    let _ = list.push((t.name.clone(), t.frame_share_us()));
                }
                list.sort_unstable_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
                return Err(ScheduleError::Overbooked {
                    frame,
                    needed_us: needed,
                    minor_frame_us,
                    margin_us,
                    tasks: list,
                });
            }
        }
        let mut table = heapless::Vec::new();
        for t in tasks {
            let _ = table.push(t.clone());
        }
        Ok(Schedule {
            minor_frame_us,
            margin_us,
            hyperperiod,
            tasks: table,
        })
    }

    pub fn minor_frame_us(&self) -> u32 {
        self.minor_frame_us
    }

    pub fn margin_us(&self) -> u32 {
        self.margin_us
    }

    /// Frames after which the pattern of rate groups repeats.
    pub fn hyperperiod(&self) -> u64 {
        self.hyperperiod
    }

    pub fn tasks(&self) -> &[TaskSpec] {
        &self.tasks
    }

    /// Index of the task called `name`.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.tasks.iter().position(|t| t.name.as_str() == name)
    }

    /// Worst-case load over the hyperperiod, in microseconds of the busiest frame.
    pub fn busiest_frame_us(&self) -> u64 {
        (0..self.hyperperiod)
            .map(|f| {
                self.tasks
                    .iter()
                    .filter(|t| t.rate.runs_in(f))
                    .map(|t| t.frame_share_us() as u64)
                    .sum::<u64>()
            })
            .max()
            .unwrap_or(0)
    }
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}

fn lcm(a: u64, b: u64) -> u64 {
    a / gcd(a, b) * b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::{AnytimeSpec, OverrunPolicy, RateGroup};

    fn task(name: &str, divisor: u32, offset: u32, budget: u32) -> TaskSpec {
        TaskSpec::periodic(
            name,
            RateGroup::new(divisor, offset),
            budget,
            OverrunPolicy::Skip,
        )
    }

    #[test]
    fn rate_group_runs_in_its_frames() {
        let g = RateGroup::new(10, 3);
        let frames: Vec<u64> = (0..40).filter(|&f| g.runs_in(f)).collect();
        assert_eq!(frames, vec![3, 13, 23, 33]);
    }

    #[test]
    fn fitting_schedule_is_accepted() {
        let s = Schedule::build(
            10_000,
            500,
            &[
                task("a", 1, 0, 4000),
                task("b", 2, 0, 2000),
                task("c", 2, 1, 5000),
            ],
        )
        .expect("fits");
        assert_eq!(s.hyperperiod(), 2);
        assert_eq!(s.busiest_frame_us(), 9000);
    }

    #[test]
    fn overbooked_frame_is_named_with_its_tasks() {
        let err = Schedule::build(
            10_000,
            500,
            &[task("odometry", 1, 0, 4000), task("planner", 10, 3, 6000)],
        )
        .expect_err("frame 3 is overbooked");
        match &err {
            ScheduleError::Overbooked {
                frame,
                needed_us,
                tasks,
                ..
            } => {
                assert_eq!(*frame, 3);
                assert_eq!(*needed_us, 10_500);
                assert_eq!(tasks[0].0.as_str(), "planner");
            }
            other => panic!("unexpected {other:?}"),
        }
        let msg = err.to_string();
        assert!(msg.contains("frame 3"), "{msg}");
        assert!(msg.contains("planner 6000 us"), "{msg}");
        assert!(msg.contains("odometry 4000 us"), "{msg}");
    }

    #[test]
    fn margin_counts() {
        assert!(Schedule::build(1000, 0, &[task("a", 1, 0, 1000)]).is_ok());
        assert!(Schedule::build(1000, 1, &[task("a", 1, 0, 1000)]).is_err());
    }

    #[test]
    fn invalid_declarations_are_refused() {
        assert!(matches!(
            Schedule::build(1000, 0, &[task("a", 0, 0, 10)]),
            Err(ScheduleError::BadRateGroup { .. })
        ));
        assert!(matches!(
            Schedule::build(1000, 0, &[task("a", 4, 4, 10)]),
            Err(ScheduleError::BadRateGroup { .. })
        ));
        assert!(matches!(
            Schedule::build(1000, 0, &[task("a", 1, 0, 0)]),
            Err(ScheduleError::ZeroBudget { .. })
        ));
        assert!(matches!(
            Schedule::build(1000, 0, &[task("a", 1, 0, 10), task("a", 2, 0, 10)]),
            Err(ScheduleError::DuplicateName { .. })
        ));
        let bad = TaskSpec::anytime(
            "p",
            RateGroup::EVERY_FRAME,
            100,
            OverrunPolicy::Skip,
            AnytimeSpec {
                quantum: 10,
                steps: 20,
                window_us: 1000,
            },
        );
        assert!(matches!(
            Schedule::build(10_000, 0, &[bad]),
            Err(ScheduleError::BadAnytime { .. })
        ));
        assert!(matches!(
            Schedule::build(
                1000,
                0,
                &[task("a", 999_983, 0, 1), task("b", 999_979, 0, 1)]
            ),
            Err(ScheduleError::HyperperiodTooLong { .. })
        ));
    }

    #[test]
    fn anytime_tasks_are_charged_their_window() {
        let planner = TaskSpec::anytime(
            "planner",
            RateGroup::EVERY_FRAME,
            100,
            OverrunPolicy::Skip,
            AnytimeSpec {
                quantum: 50,
                steps: 40,
                window_us: 6000,
            },
        );
        assert!(Schedule::build(10_000, 0, &[planner.clone(), task("a", 1, 0, 4000)]).is_ok());
        assert!(Schedule::build(10_000, 0, &[planner, task("a", 1, 0, 4001)]).is_err());
    }
}
