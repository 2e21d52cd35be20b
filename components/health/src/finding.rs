//! The health monitor's findings, one bit each.

pub const IMU_SILENT: u16 = 1 << 0;
pub const IMU_GARBAGE: u16 = 1 << 1;
pub const LIDAR_SILENT: u16 = 1 << 2;
pub const DRIVE_SILENT: u16 = 1 << 3;
pub const DRIVE_FAULT: u16 = 1 << 4;
pub const CAN_ERROR: u16 = 1 << 5;
pub const WHEEL: u16 = 1 << 6;
pub const OVERRUN_STORM: u16 = 1 << 7;
pub const CLOCK_JUMP: u16 = 1 << 8;

pub const NAMES: [(u16, &str); 9] = [
    (IMU_SILENT, "imu_silent"),
    (IMU_GARBAGE, "imu_garbage"),
    (LIDAR_SILENT, "lidar_silent"),
    (DRIVE_SILENT, "drive_silent"),
    (DRIVE_FAULT, "drive_fault"),
    (CAN_ERROR, "can_error"),
    (WHEEL, "wheel"),
    (OVERRUN_STORM, "overrun_storm"),
    (CLOCK_JUMP, "clock_jump"),
];

/// The names of the findings in `mask`.
pub fn names(mask: u16) -> impl Iterator<Item = &'static str> + Clone {
    NAMES
        .iter()
        .filter(move |(bit, _)| mask & bit != 0)
        .map(|(_, n)| *n)
}
