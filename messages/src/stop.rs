//! Why the safety monitor stopped the rover.

/// Why the safety monitor stopped the rover. The numbers are the report's and
/// the bus's codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum StopReason {
    /// Ahead there is no ground over a longer stretch than a sensor gap.
    LeavingMap = 1,
    /// Something at body height just ahead.
    Blocked = 2,
    /// Roll or pitch beyond the limit, and growing.
    Tilt = 3,
    /// Commanded to move without moving.
    Stuck = 4,
    /// Farther from the path than the plan's margin.
    OffPath = 5,
    /// Moving, but the plan left to drive has not shrunk for a long time.
    NoProgress = 6,
}

impl StopReason {
    pub const ALL: [StopReason; 6] = [
        StopReason::LeavingMap,
        StopReason::Blocked,
        StopReason::Tilt,
        StopReason::Stuck,
        StopReason::OffPath,
        StopReason::NoProgress,
    ];

    pub fn name(self) -> &'static str {
        match self {
            StopReason::LeavingMap => "leaving_map",
            StopReason::Blocked => "blocked",
            StopReason::Tilt => "tilt",
            StopReason::Stuck => "stuck",
            StopReason::OffPath => "off_path",
            StopReason::NoProgress => "no_progress",
        }
    }
}
