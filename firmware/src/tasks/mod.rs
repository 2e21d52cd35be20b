//! The on-board tasks, one file each. Every task reads and writes only the
//! [`crate::bus::Bus`] and its own state.

pub mod control;
pub mod drive_driver;
pub mod drive_output;
pub mod health;
pub mod imu_driver;
pub mod io;
pub mod lidar_driver;
pub mod maps;
pub mod odometry;
pub mod planner;
pub mod recorder;
pub mod slam;
