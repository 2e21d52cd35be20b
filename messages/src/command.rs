//! What the path follower asks of the wheels.

use crate::StopReason;

/// The path follower's command.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelCommand {
    pub speed: f64,
    pub yaw_rate: f64,
    /// rad/s: front left, front right, rear left, rear right.
    pub wheel_speeds: [f64; 4],
    pub segment: u32,
    pub done: bool,
    /// The plan being followed (its query number; 0: the configured path).
    pub plan: u64,
    /// Why the safety monitor stopped the rover on this plan, if it did.
    pub stop: Option<StopReason>,
    /// Where that stop's probe saw a drop ahead (a `LeavingMap` stop at a
    /// rim, x and y in the map frame).
    pub rim: Option<[f64; 2]>,
}
