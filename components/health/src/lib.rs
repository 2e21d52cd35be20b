//! The rover's health: freshness of every watched source, and the monitor
//! that names what is wrong (a device gone quiet, an IMU line talking
//! noise, a drive fault, CAN errors, a wheel the odometry leaves out, a
//! storm of overruns, a clock that jumped) and whether the safe schedule
//! is asked for or may be left.

pub mod finding;
mod freshness;
mod monitor;

pub use freshness::{Freshness, Source, SourceId, MAX_SOURCES};
pub use monitor::{
    DriveHealth, HealthInput, HealthMonitor, HealthParams, HealthVerdict, SOURCE_NAMES,
};
