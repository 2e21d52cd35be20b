//! Graph SLAM as an anytime task. `run` takes each new LiDAR revolution that
//! should become a keyframe (moved into the base frame and deskewed with the
//! odometry history) and publishes the map pose every frame; each `step`
//! does one bounded unit of the keyframe's work (prepare the cloud, one
//! registration, insert the factors, one Levenberg-Marquardt iteration).

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use speleo_scheduler::{Context, StepResult, Task};
use speleo_slam::deskew::deskew;
use speleo_slam::graph_slam::{GraphSlam, SlamParams};
use speleo_slam::lie::Pose;

use crate::bus::{Bus, SlamPose};

/// Returns closer than this hit the rover itself.
const MIN_RANGE_M: f32 = 0.6;

pub struct SlamTask {
    slam: GraphSlam,
    /// `slam.enabled`: when off, the task publishes the odometry pose.
    enabled: bool,
    /// LiDAR mount: base <- sensor.
    mount: Pose,
    cloud_seen: u64,
    points: Vec<[f64; 3]>,
    times: Vec<f32>,
    /// Revolutions that could not be placed in the odometry history.
    pub scans_without_odometry: u64,
    pub points_not_deskewed: u64,
}

impl SlamTask {
    pub fn new(p: SlamParams, enabled: bool, mount: Pose, max_cloud_points: usize) -> Self {
        SlamTask {
            slam: GraphSlam::new(p),
            enabled,
            mount,
            cloud_seen: 0,
            points: Vec::with_capacity(max_cloud_points),
            times: Vec::with_capacity(max_cloud_points),
            scans_without_odometry: 0,
            points_not_deskewed: 0,
        }
    }

    pub fn slam(&self) -> &GraphSlam {
        &self.slam
    }

    fn take_cloud(&mut self, bus: &Bus) {
        let Some(c) = bus.cloud.newer_than(self.cloud_seen) else {
            return;
        };
        self.cloud_seen = c.seq;
        if !self.slam.is_idle() {
            return;
        }
        let cloud = &c.value;
        let last = cloud.points.last().map_or(0.0, |p| p.time);
        // The cloud is stamped when its last packet arrived.
        let t0 = c.stamp_ns.saturating_sub((last as f64 * 1e9) as u64);
        let Some(odom0) = bus.odom_history.at(t0) else {
            self.scans_without_odometry += 1;
            return;
        };
        let odom0 = Pose::from_isometry(&odom0);
        if !self.slam.wants_keyframe(&odom0) {
            return;
        }
        self.points.clear();
        self.times.clear();
        for p in &cloud.points {
            if p.distance < MIN_RANGE_M || self.points.len() == self.points.capacity() {
                continue;
            }
            let v = self
                .mount
                .transform(&Vector3::new(p.x as f64, p.y as f64, p.z as f64));
            self.points.push([v.x, v.y, v.z]);
            self.times.push(p.time);
        }
        let history = &bus.odom_history;
        self.points_not_deskewed += deskew(&mut self.points, &self.times, |dt| {
            history
                .at(t0 + (dt * 1e9) as u64)
                .map(|iso: Isometry3<f64>| Pose::from_isometry(&iso))
        }) as u64;
        let up = bus.imu.latest().map_or(Vector3::z(), |s| {
            let [w, x, y, z] = s.value.orientation;
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
            q.inverse() * Vector3::z()
        });
        self.slam
            .offer_scan(t0, odom0, up, self.points.iter().copied());
    }
}

impl Task<Bus> for SlamTask {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        if self.enabled {
            self.take_cloud(bus);
        }
        if let Some(o) = bus.odom.get() {
            let [w, x, y, z] = o.value.orientation;
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
            let odom = Pose::new(
                *q.to_rotation_matrix().matrix(),
                Vector3::from(o.value.position),
            );
            let p = self.slam.pose(&odom);
            let q = UnitQuaternion::from_rotation_matrix(
                &nalgebra::Rotation3::from_matrix_unchecked(p.r),
            );
            bus.slam.publish(
                cx.time_ns,
                SlamPose {
                    position: p.t.into(),
                    orientation: [q.w, q.i, q.j, q.k],
                    keyframes: self.slam.keyframes().len() as u32,
                },
            );
        }
    }

    fn step(&mut self, _bus: &mut Bus, _cx: &Context, quantum: u32) -> StepResult {
        for _ in 0..quantum.max(1) {
            if !self.slam.step() {
                return StepResult::Idle;
            }
        }
        StepResult::Continue
    }
}
