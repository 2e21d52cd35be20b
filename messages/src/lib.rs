//! The messages the rover's tasks exchange through the bus's mailboxes.
//! Plain data: no task, mailbox or schedule knows more of another task than
//! the message types here.

pub mod attitude;
mod command;
mod drives;
mod exploration;
mod health;
mod plan;
mod pose;
mod raw;
mod sensors;
mod stop;

pub use command::WheelCommand;
pub use drives::DriveFeedback;
pub use exploration::{ExplorationPhase, ExplorationStatus};
pub use health::{Counters, HealthReport, Timing};
pub use plan::{PlanMsg, PLAN_POSES};
pub use pose::{OdomPose, SlamPose};
pub use raw::{RawEntry, RawFrame, RAW_ARENA_BYTES, RAW_ENTRIES};
pub use sensors::{Cloud, ImuSample, LidarCounters};
pub use stop::StopReason;
