//! Taps every mailbox once per frame and records what is new: the frame's raw
//! inputs, the CAN frames queued for the drives, IMU samples, drive feedback,
//! odometry, the SLAM pose, the frame tree (map -> odom -> base_link ->
//! sensors), wheel commands, diagnostics, the route and the planner's path.

use std::cell::RefCell;

use nalgebra::Isometry3;
use speleo_scheduler::{Context, Task};

use crate::bus::Bus;
use crate::record::diagnostics::emit_health;
use crate::record::messages::{
    emit_can_tx, emit_drives, emit_imu, emit_marker_line, emit_path, emit_wheel_command, raw_topic,
    write_cloud, MarkerLine,
};
use crate::record::motion::{
    body_velocity, emit_fixed_frames, emit_odometry, emit_slam_pose, isometry,
};
use crate::record::{RecorderTap, Topic};

/// The route and the fixed frames are re-sent this often (frames) so a
/// viewer that seeks finds them.
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
    /// The previous odometry pose and its stamp, for the velocity.
    last_odom: Option<(u64, Isometry3<f64>)>,
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
            last_odom: None,
        }
    }

    /// Record only every `n`th decoded revolution.
    pub fn with_cloud_every(mut self, n: u32) -> Self {
        self.cloud_every = n.max(1) as u64;
        self
    }
}

impl RecorderTask<'_> {
    /// The odometry pose, with the velocity since the previous one.
    fn record_odometry(&mut self, tap: &mut RecorderTap, frame: u64, now: u64, bus: &Bus) {
        let Some(o) = bus.odom.newer_than(self.odom_seen) else {
            return;
        };
        self.odom_seen = o.seq;
        let here = isometry(o.value.position, o.value.orientation);
        let velocity = match &self.last_odom {
            Some((t, before)) => body_velocity(before, &here, (o.stamp_ns - t) as f64 * 1e-9),
            None => ([0.0; 3], [0.0; 3]),
        };
        self.last_odom = Some((o.stamp_ns, here));
        let pose = (o.value.position, o.value.orientation);
        emit_odometry(tap, (frame, now, o.stamp_ns), pose, velocity);
    }

    /// The SLAM pose, once SLAM has a map (before its first keyframe it
    /// repeats the odometry, and map and odom coincide).
    fn record_slam(&mut self, tap: &mut RecorderTap, frame: u64, now: u64, bus: &Bus) {
        let Some(o) = bus.slam.newer_than(self.slam_seen) else {
            return;
        };
        self.slam_seen = o.seq;
        if o.value.keyframes == 0 {
            return;
        }
        // The odometry pose SLAM's pose was computed from this frame.
        let odom = bus
            .odom
            .get()
            .map(|d| (d.value.position, d.value.orientation));
        let map_base = (o.value.position, o.value.orientation);
        emit_slam_pose(tap, (frame, now, o.stamp_ns), map_base, odom);
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
            emit_can_tx(&mut tap, (frame, now), bus.can_tx.len(), bus.can_tx.iter());
        }

        let tap_ref = &mut *tap;
        bus.imu
            .read_since(&mut self.imu_cursor, |s| emit_imu(tap_ref, (frame, now), s));

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
        }

        if frame.is_multiple_of(PLAN_EVERY_FRAMES) {
            emit_fixed_frames(&mut tap, (frame, now), self.lidar_mount);
        }
        self.record_odometry(&mut tap, frame, now, bus);
        self.record_slam(&mut tap, frame, now, bus);

        if let Some(c) = bus.command.newer_than(self.command_seen) {
            self.command_seen = c.seq;
            emit_wheel_command(&mut tap, (frame, now), c);
        }

        if let Some(h) = bus.health.newer_than(self.health_seen) {
            self.health_seen = h.seq;
            let counters = &bus.counters;
            emit_health(&mut tap, (frame, now), h, cx.mode, bus.imu_config, counters);
        }

        if frame.is_multiple_of(PLAN_EVERY_FRAMES) {
            let route = self.plan.iter().map(|p| [p[0], p[1], 0.0]);
            let line = MarkerLine {
                frame_id: "odom",
                ns: "route",
                looped: self.plan_looped,
                color: [0.1, 0.8, 0.3],
            };
            emit_marker_line(&mut tap, Topic::Plan, (frame, now, now), &line, route);
        }
        if let Some(p) = bus.plan.newer_than(self.planner_seen) {
            self.planner_seen = p.seq;
            // The planner's path over the ground, in the SLAM map frame.
            let poses = p.value.poses.iter().map(|q| (*q).map(f64::from));
            emit_path(
                &mut tap,
                Topic::PlannerPath,
                (frame, now, p.stamp_ns),
                "map",
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
