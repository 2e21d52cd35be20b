//! Speleo's cyclic executive.
//!
//! One deterministic, fixed-rate executive runs every on-board task. Time is cut
//! into minor frames (10 ms by default); each task belongs to a rate group given
//! by a divisor and an offset, declares a time budget and an overrun policy, and
//! exchanges data with other tasks only through fixed-capacity [`mailbox`]es.
//!
//! The core is `#![no_std]` and allocation-free: every table has a fixed capacity
//! ([`MAX_TASKS`]). The `std` feature adds the real monotonic clock, real-time
//! setup (`SCHED_FIFO`, `mlockall`) and the [`accounting`] allocator that
//! attributes every heap allocation to the task that made it.
//!
//! Determinism: on a [`clock::VirtualClock`] time advances exactly one minor
//! frame per frame, anytime tasks do a fixed number of fixed work quanta per run,
//! and overrun policies (which depend on measured wall time) are only enforced
//! when [`executive::Enforcement::Enforce`] is chosen, so outputs never depend on
//! machine speed.
#![cfg_attr(not(feature = "std"), no_std)]

pub mod clock;
pub mod events;
pub mod executive;
pub mod histogram;
pub mod mailbox;
pub mod schedule;
pub mod spec;
pub mod stats;
pub mod task;

#[cfg(feature = "std")]
pub mod accounting;
#[cfg(feature = "std")]
pub mod coprocessor;
#[cfg(feature = "std")]
pub mod realtime;

pub use clock::{FrameClock, Platform, VirtualClock};
pub use executive::{Enforcement, Executive, FrameReport};
pub use schedule::{Schedule, ScheduleError};
pub use spec::{AnytimeSpec, OverrunPolicy, RateGroup, TaskName, TaskSpec};
pub use stats::{CpuFigures, TaskStats};
pub use task::{Context, Mode, StepResult, Task};

/// Most tasks one schedule can hold (fixed so the tables need no heap).
pub const MAX_TASKS: usize = 32;
