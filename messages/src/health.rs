//! What health concludes and the figures it concludes from.

use speleo_hal::xbus::XbusCounters;

/// What the health task concluded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HealthReport {
    pub stale_mask: u32,
    pub drive_faults: u8,
    /// The health task's finding bits (`tasks::health::finding`).
    pub findings: u16,
    pub safe_mode: bool,
}

/// The executive's own figures, mirrored between frames for health.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Timing {
    /// Task runs over budget so far.
    pub overruns: u64,
    /// Frames the clock skipped so far.
    pub slipped_frames: u64,
    /// The executive applies its overrun policies (real time, or a budget
    /// test on virtual time).
    pub enforcing: bool,
}

/// Counters every driver keeps, reported by health.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    pub imu: XbusCounters,
    pub imu_bad_items: u64,
    pub imu_other_messages: u64,
    pub can_frames: u64,
    pub can_malformed: u64,
    pub can_unmapped: u64,
    pub can_bad_length: u64,
    pub raw_dropped: u64,
    pub can_tx_dropped: u64,
    pub hal_errors: u64,
    /// Errors of the CAN controller (bus-off), sending or receiving.
    pub can_errors: u64,
    /// Input the CAN transport could not make into frames (an slcan
    /// adapter's bad lines), dropped.
    pub can_transport_dropped: u64,
    pub imu_samples_lost: u64,
}
