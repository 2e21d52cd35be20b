//! Wheel and IMU odometry at the frame rate: publishes the pose every frame
//! and keeps the recent poses, stamped with the frame time (the pose carried
//! on to it from the last IMU and wheel samples), in the bus's pose history
//! for deskewing.

use speleo_odometry::{ImuInput, Odometry, OdometryParams};
use speleo_scheduler::{Context, Task};

use crate::bus::Bus;
use speleo_messages::OdomPose;

/// Step the wheels with whatever positions there are when some drive has
/// not sent a new one for this long (its wheel is then left out as stuck).
const STALE_POSITION_NS: u64 = 25_000_000;

pub struct OdometryTask {
    odo: Odometry,
    imu_cursor: u64,
    drives_seen: u64,
    /// Receive times of the positions of the last wheel step.
    positions_used: [u64; 4],
    last_step_ns: u64,
    /// This run pushed a pose to the history (undone on retraction).
    pushed: bool,
}

impl OdometryTask {
    pub fn new(p: OdometryParams) -> Self {
        OdometryTask {
            odo: Odometry::new(p),
            imu_cursor: 0,
            drives_seen: 0,
            positions_used: [0; 4],
            last_step_ns: 0,
            pushed: false,
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
            let times = [0, 1, 2, 3].map(|i| n[i].position_time_ns);
            let newest = times.iter().copied().max().unwrap_or(0);
            // Only once every drive has reported a position, and when every
            // position is new (the four answers to one SYNC), or when one
            // has gone stale.
            let fresh = (0..4).all(|i| times[i] > self.positions_used[i]);
            let stale = newest.saturating_sub(self.last_step_ns) > STALE_POSITION_NS
                && times != self.positions_used;
            if times.iter().all(|t| *t != 0) && (fresh || stale) {
                odo.wheels(
                    newest,
                    [n[0].position, n[1].position, n[2].position, n[3].position],
                );
                self.positions_used = times;
                self.last_step_ns = newest;
            }
        }
        // Carried on from the last samples to the frame's time, which the
        // pose is stamped with.
        let pose = odo.pose_at(cx.time_ns);
        let q = pose.rotation.into_inner();
        bus.odom.publish(
            cx.time_ns,
            OdomPose {
                position: pose.translation.vector.into(),
                orientation: [q.w, q.i, q.j, q.k],
                distance_m: odo.distance_m(),
            },
        );
        self.pushed = bus.odom_history.push(cx.time_ns, pose);
        bus.odom_counters = *odo.counters();
    }

    fn retract(&mut self, bus: &mut Bus) {
        bus.odom.retract();
        if self.pushed {
            bus.odom_history.pop_newest();
            self.pushed = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use speleo_hal::canopen::supervisor::DrivesState;

    use crate::tasks::test_context as cx;

    /// All four drives report `counts` at `t_ns`, except those in `late`.
    fn drives(bus: &mut Bus, t_ns: u64, counts: i32, late: &[usize]) {
        let mut s = bus.drives.get().map_or(DrivesState::default(), |d| d.value);
        for (i, n) in s.nodes.iter_mut().enumerate() {
            if !late.contains(&i) {
                n.position = counts;
                n.position_time_ns = t_ns;
            }
        }
        bus.drives.publish(t_ns, s);
    }

    /// A task whose wheels roll 1 m per 1000 counts.
    fn metre_per_1000_counts() -> OdometryTask {
        OdometryTask::new(OdometryParams {
            counts_per_rev: 1000.0,
            wheel_radius_m: 1.0 / (2.0 * core::f64::consts::PI),
            ..OdometryParams::default()
        })
    }

    #[test]
    fn publishes_every_frame_and_keeps_the_pose_history() {
        let mut bus = Bus::new();
        let mut t = metre_per_1000_counts();
        // 1000 counts = 1 m; 10 counts a frame.
        for f in 0..300u64 {
            drives(&mut bus, f * 10_000_000 + 500_000, 10 * f as i32, &[]);
            t.run(&mut bus, &cx(f));
            assert_eq!(bus.odom.get().map(|o| o.stamp_ns), Some(f * 10_000_000));
        }
        let x = bus.odom.get().map(|o| o.value.position[0]);
        assert!((x.unwrap_or(0.0) - 2.99).abs() < 1e-9, "{x:?}");
        let h = &bus.odom_history;
        assert_eq!(h.len(), crate::bus::ODOM_HISTORY_LEN);
        assert_eq!(h.span(), Some((44 * 10_000_000, 299 * 10_000_000)));
        let p = h.at(150 * 10_000_000 + 5_000_000).map(|p| p.translation.x);
        assert!((p.unwrap_or(0.0) - 1.505).abs() < 1e-9, "{p:?}");
        assert_eq!(bus.odom_counters.wheel_steps, 299);

        // A retracted run takes its pose back out of the history.
        t.retract(&mut bus);
        assert_eq!(bus.odom_history.span().map(|s| s.1), Some(298 * 10_000_000));
    }

    #[test]
    fn waits_for_all_four_positions_of_a_sync() {
        let mut bus = Bus::new();
        let mut t = metre_per_1000_counts();
        drives(&mut bus, 1_000, 0, &[]);
        t.run(&mut bus, &cx(0));
        // Rear right's answer comes a frame late: no step, then one.
        drives(&mut bus, 10_001_000, 10, &[3]);
        t.run(&mut bus, &cx(1));
        assert_eq!(bus.odom_counters.wheel_steps, 0);
        drives(&mut bus, 10_002_000, 10, &[0, 1, 2]);
        t.run(&mut bus, &cx(2));
        assert_eq!(bus.odom_counters.wheel_steps, 1);
        assert_eq!(bus.odom_counters.slip_steps, 0);
        // Rear right goes silent: after 25 ms the others carry on without
        // it (the gyro, saying straight, tells which side is right).
        for f in 3..10u64 {
            let level = speleo_messages::ImuSample {
                orientation: [1.0, 0.0, 0.0, 0.0],
                ..Default::default()
            };
            bus.imu.publish(f * 10_000_000 - 5_000_000, level);
            drives(&mut bus, f * 10_000_000, 10 * f as i32, &[3]);
            t.run(&mut bus, &cx(f));
        }
        let c = bus.odom_counters;
        assert!(
            c.wheel_steps >= 3 && c.wheel_slips == [0, 0, 0, c.slip_steps],
            "{c:?}"
        );
        let x = bus.odom.get().map_or(0.0, |o| o.value.position[0]);
        assert!((x - 0.08).abs() < 0.011, "{x}");
    }
}
