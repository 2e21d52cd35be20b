//! MCAP recording (ROS 2 profile): every raw input and every task output as
//! a ROS 2 message in CDR with its schema, so a run opens in Foxglove,
//! rosbag2 and rviz2, and replays exactly.

pub mod cdr;
pub mod cdr_json;
pub mod compare;
pub mod diagnostics;
pub mod encode;
pub mod flatten;
pub mod frame_timing;
mod length_check;
pub mod live;
pub mod messages;
pub mod motion;
pub mod msg_def;
pub mod read;
pub mod ros2;
pub mod schemas;
pub mod tap;
pub mod topics;
pub mod writer;

pub use tap::RecorderTap;
pub use topics::{Role, Topic};
