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

/// The context of frame `frame` of 10 ms frames in nominal mode, for task
/// tests.
#[cfg(test)]
pub(crate) fn test_context(frame: u64) -> speleo_scheduler::Context {
    speleo_scheduler::Context {
        frame,
        time_ns: frame * 10_000_000,
        minor_frame_ns: 10_000_000,
        mode: speleo_scheduler::Mode::Nominal,
        degraded: false,
    }
}
