//! Follows the configured path with pure pursuit and commands wheel speeds.
//! The rover's pose is the SLAM estimate (the odometry pose corrected by the
//! pose graph; the odometry pose itself while SLAM is off), so the path stays
//! tied to the walls while the odometry drifts.

use speleo_control::{PurePursuit, SkidSteer};
use speleo_scheduler::{Context, Task};

use crate::bus::{Bus, WheelCommand};

pub struct ControlTask {
    follower: PurePursuit,
    skid: SkidSteer,
    /// Reduced mode: half speed.
    degraded: bool,
}

impl ControlTask {
    pub fn new(follower: PurePursuit, skid: SkidSteer) -> Self {
        ControlTask {
            follower,
            skid,
            degraded: false,
        }
    }
}

/// Heading (yaw about z) of a (w, x, y, z) quaternion.
pub fn yaw_of(q: [f64; 4]) -> f64 {
    let [w, x, y, z] = q;
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

impl Task<Bus> for ControlTask {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let Some(pose) = bus.slam.get() else {
            return;
        };
        let p = pose.value;
        let mut t = self
            .follower
            .command(p.position[0], p.position[1], yaw_of(p.orientation));
        if self.degraded {
            t.v *= 0.5;
            t.w *= 0.5;
        }
        bus.command.publish(
            cx.time_ns,
            WheelCommand {
                speed: t.v,
                yaw_rate: t.w,
                wheel_speeds: self.skid.wheel_speeds(t.v, t.w),
                segment: self.follower.segment() as u32,
                done: self.follower.done(),
            },
        );
    }

    fn set_degraded(&mut self, degraded: bool) {
        self.degraded = degraded;
    }

    fn retract(&mut self, bus: &mut Bus) {
        bus.command.retract();
    }
}
