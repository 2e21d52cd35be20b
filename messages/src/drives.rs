//! What the drives report back, in SI units: the navigator's energy meter
//! reads it.

use speleo_hal::canopen::supervisor::{DrivesState, WHEELS};
use speleo_hal::cia402;

/// Each wheel's velocity and, where the drive maps it, torque.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DriveFeedback {
    /// Wheel speed, rad/s at the wheel.
    pub speed: [f64; WHEELS],
    /// Torque actual at the wheel, N m (`None`: not mapped or not yet seen).
    pub torque_nm: [Option<f64>; WHEELS],
}

impl From<&DrivesState> for DriveFeedback {
    fn from(d: &DrivesState) -> Self {
        DriveFeedback {
            speed: d.nodes.map(|n| n.velocity as f64 * 1e-3),
            torque_nm: d.nodes.map(|n| n.torque.map(cia402::torque_nm)),
        }
    }
}
