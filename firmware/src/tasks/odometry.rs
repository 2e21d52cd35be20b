//! Wheel and IMU odometry at the frame rate.

use speleo_odometry::{ImuInput, Odometry, OdometryParams};
use speleo_scheduler::{Context, Task};

use crate::bus::{Bus, OdomPose};

pub struct OdometryTask {
    odo: Odometry,
    imu_cursor: u64,
    drives_seen: u64,
}

impl OdometryTask {
    pub fn new(p: OdometryParams) -> Self {
        OdometryTask {
            odo: Odometry::new(p),
            imu_cursor: 0,
            drives_seen: 0,
        }
    }
}

impl Task<Bus> for OdometryTask {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let odo = &mut self.odo;
        let lost = bus.imu.read_since(&mut self.imu_cursor, |s| {
            odo.imu(&ImuInput {
                time_ns: s.stamp_ns,
                gyro: s.value.rate_of_turn,
                orientation: s.value.orientation,
            })
        });
        bus.counters.imu_samples_lost += lost;
        if let Some(d) = bus.drives.newer_than(self.drives_seen) {
            self.drives_seen = d.seq;
            let n = &d.value.nodes;
            // Only once every drive has reported a position.
            if n.iter().all(|n| n.position_time_ns != 0) {
                odo.wheels([n[0].position, n[1].position, n[2].position, n[3].position]);
            }
        }
        let pose = odo.pose();
        let q = pose.rotation.into_inner();
        bus.odom.publish(
            cx.time_ns,
            OdomPose {
                position: pose.translation.vector.into(),
                orientation: [q.w, q.i, q.j, q.k],
                distance_m: odo.distance_m(),
            },
        );
    }

    fn retract(&mut self, bus: &mut Bus) {
        bus.odom.retract();
    }
}
