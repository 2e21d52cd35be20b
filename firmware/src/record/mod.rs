//! MCAP recording: every raw input and every task output, with schemas, so a
//! run opens in Foxglove and replays exactly.

pub mod cdr;
pub mod compare;
pub mod encode;
pub mod flatten;
mod length_check;
pub mod messages;
pub mod read;
pub mod tap;
pub mod topics;
pub mod writer;

pub use tap::RecorderTap;
pub use topics::{Role, Topic};
