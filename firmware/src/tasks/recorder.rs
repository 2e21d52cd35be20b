//! Taps every mailbox once per frame and records what is new: the frame's raw
//! inputs, the CAN frames queued for the drives, IMU samples, drive feedback,
//! odometry (pose and transform), wheel commands, health, and the path.

use std::cell::RefCell;

use serde::Serialize;
use speleo_scheduler::{Context, Task};

use crate::bus::Bus;
use crate::record::encode::{
    CanFrameJson, FrameTransform, ImuSampleJson, Pose, PoseInFrame, Quaternion, SeqOf,
    WheelCommandJson,
};
use crate::record::messages::{
    emit_drives, emit_health, emit_line, raw_topic, write_cloud, SceneLine, Stamped,
};
use crate::record::{RecorderTap, Topic};

/// The path is re-sent this often (frames) so a viewer that seeks finds it.
pub const PLAN_EVERY_FRAMES: u64 = 100;

pub struct RecorderTask<'r> {
    tap: &'r RefCell<RecorderTap>,
    imu_cursor: u64,
    drives_seen: u64,
    odom_seen: u64,
    slam_seen: u64,
    planner_seen: u64,
    command_seen: u64,
    health_seen: u64,
    plan: Vec<[f64; 2]>,
    plan_looped: bool,
    cloud_seen: u64,
    /// Record one revolution in this many (the raw packets hold them all).
    cloud_every: u64,
    /// base_link -> lidar: translation and (w, x, y, z) rotation.
    lidar_mount: ([f64; 3], [f64; 4]),
}

impl<'r> RecorderTask<'r> {
    pub fn new(
        tap: &'r RefCell<RecorderTap>,
        plan: Vec<[f64; 2]>,
        plan_looped: bool,
        mount_xyz: [f64; 3],
        mount_rpy_deg: [f64; 3],
    ) -> Self {
        let [r, p, y] = mount_rpy_deg.map(f64::to_radians);
        let q = nalgebra::UnitQuaternion::from_euler_angles(r, p, y).into_inner();
        RecorderTask {
            cloud_seen: 0,
            cloud_every: 1,
            lidar_mount: (mount_xyz, [q.w, q.i, q.j, q.k]),
            tap,
            imu_cursor: 0,
            drives_seen: 0,
            odom_seen: 0,
            slam_seen: 0,
            planner_seen: 0,
            command_seen: 0,
            health_seen: 0,
            plan,
            plan_looped,
        }
    }

    /// Record only every `n`th decoded revolution.
    pub fn with_cloud_every(mut self, n: u32) -> Self {
        self.cloud_every = n.max(1) as u64;
        self
    }
}

impl Task<Bus> for RecorderTask<'_> {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let Ok(mut tap) = self.tap.try_borrow_mut() else {
            return;
        };
        let (frame, now) = (cx.frame, cx.time_ns);

        for e in bus.raw.entries() {
            let bytes = bus.raw.bytes_of(e);
            tap.raw(
                raw_topic(e.device),
                e.device.name(),
                frame,
                now,
                e.receive_time_ns,
                bytes,
            );
        }

        for m in bus.imu_tx.iter() {
            tap.raw(Topic::ImuTx, "imu", frame, now, now, m);
        }

        if !bus.can_tx.is_empty() {
            let ts = tap.time(now);
            let frames = SeqOf::new(bus.can_tx.iter().map(|f| CanFrameJson {
                id: f.id,
                data: f.payload(),
            }));
            #[derive(Serialize)]
            struct Frames<S> {
                frames: S,
            }
            let msg = Stamped {
                timestamp: ts,
                body: Frames { frames },
            };
            tap.emit(Topic::CanTx, frame, now, now, |w| {
                serde_json::to_writer(w, &msg)
            });
        }

        let tap_ref = &mut *tap;
        bus.imu.read_since(&mut self.imu_cursor, |s| {
            let v = &s.value;
            let msg = ImuSampleJson {
                timestamp: tap_ref.time(s.stamp_ns),
                packet_counter: v.packet_counter,
                sample_time_fine: v.sample_time_fine,
                orientation: Quaternion::wxyz(v.orientation),
                acceleration: v.acceleration.into(),
                rate_of_turn: v.rate_of_turn.into(),
                status_word: v.status_word,
            };
            tap_ref.emit(Topic::Imu, frame, now, s.stamp_ns, |w| {
                serde_json::to_writer(w, &msg)
            });
        });

        if let Some(d) = bus.drives.newer_than(self.drives_seen) {
            self.drives_seen = d.seq;
            let stop = bus.drive_stop.get().map(|s| s.value).unwrap_or_default();
            emit_drives(&mut tap, frame, now, d, stop);
        }

        if let Some(c) = bus
            .cloud
            .newer_than(self.cloud_seen)
            .filter(|c| (c.seq - 1).is_multiple_of(self.cloud_every))
        {
            self.cloud_seen = c.seq;
            let ts = tap.time(c.stamp_ns);
            let points = &c.value.points;
            tap.emit_large(Topic::Cloud, frame, now, c.stamp_ns, |w| {
                write_cloud(w, ts, points)
            });
            let (xyz, q) = self.lidar_mount;
            let tf = FrameTransform {
                timestamp: ts,
                parent_frame_id: "base_link",
                child_frame_id: "lidar",
                translation: xyz.into(),
                rotation: Quaternion::wxyz(q),
            };
            tap.emit(Topic::Tf, frame, now, c.stamp_ns, |w| {
                serde_json::to_writer(w, &tf)
            });
        }

        if let Some(o) = bus.odom.newer_than(self.odom_seen) {
            self.odom_seen = o.seq;
            let ts = tap.time(o.stamp_ns);
            let pose = PoseInFrame {
                timestamp: ts,
                frame_id: "odom",
                pose: Pose {
                    position: o.value.position.into(),
                    orientation: Quaternion::wxyz(o.value.orientation),
                },
            };
            tap.emit(Topic::Odom, frame, now, o.stamp_ns, |w| {
                serde_json::to_writer(w, &pose)
            });
            let tf = FrameTransform {
                timestamp: ts,
                parent_frame_id: "odom",
                child_frame_id: "base_link",
                translation: o.value.position.into(),
                rotation: Quaternion::wxyz(o.value.orientation),
            };
            tap.emit(Topic::Tf, frame, now, o.stamp_ns, |w| {
                serde_json::to_writer(w, &tf)
            });
        }

        if let Some(o) = bus.slam.newer_than(self.slam_seen) {
            self.slam_seen = o.seq;
            // Only once SLAM has a map (before its first keyframe it repeats
            // the odometry).
            if o.value.keyframes > 0 {
                let pose = PoseInFrame {
                    timestamp: tap.time(o.stamp_ns),
                    frame_id: "map",
                    pose: Pose {
                        position: o.value.position.into(),
                        orientation: Quaternion::wxyz(o.value.orientation),
                    },
                };
                tap.emit(Topic::SlamPose, frame, now, o.stamp_ns, |w| {
                    serde_json::to_writer(w, &pose)
                });
            }
        }

        if let Some(c) = bus.command.newer_than(self.command_seen) {
            self.command_seen = c.seq;
            let msg = WheelCommandJson {
                timestamp: tap.time(c.stamp_ns),
                speed: c.value.speed,
                yaw_rate: c.value.yaw_rate,
                wheel_speeds: c.value.wheel_speeds,
                segment: c.value.segment,
                done: c.value.done,
            };
            tap.emit(Topic::WheelCommand, frame, now, c.stamp_ns, |w| {
                serde_json::to_writer(w, &msg)
            });
        }

        if let Some(h) = bus.health.newer_than(self.health_seen) {
            self.health_seen = h.seq;
            let counters = &bus.counters;
            emit_health(&mut tap, (frame, now), h, cx.mode, bus.imu_config, counters);
        }

        if frame % PLAN_EVERY_FRAMES == 0 {
            let route = self.plan.iter().map(|p| [p[0], p[1], 0.0]);
            let looped = self.plan_looped;
            let line = SceneLine {
                frame_id: "odom",
                id: "plan",
                looped,
                color: [0.1, 0.8, 0.3],
            };
            emit_line(&mut tap, Topic::Plan, frame, now, now, &line, route);
        }
        if let Some(p) = bus.plan.newer_than(self.planner_seen) {
            self.planner_seen = p.seq;
            // The planner's path over the ground, in the SLAM map frame.
            let poses = p
                .value
                .poses
                .iter()
                .map(|q| [q[0] as f64, q[1] as f64, q[2] as f64]);
            let line = SceneLine {
                frame_id: "map",
                id: "planner_path",
                looped: false,
                color: if p.value.optimal {
                    [0.2, 0.4, 1.0]
                } else {
                    [1.0, 0.6, 0.1]
                },
            };
            emit_line(
                &mut tap,
                Topic::PlannerPath,
                frame,
                now,
                p.stamp_ns,
                &line,
                poses,
            );
        }
        if let Some(c) = tap.comparer_mut() {
            c.end_frame(frame);
        }
    }

    fn set_degraded(&mut self, _degraded: bool) {
        // The recorder has no reduced mode: losing records is worse than
        // losing time, and in real time the pool already drops (and counts)
        // what the disk cannot take.
    }
}
