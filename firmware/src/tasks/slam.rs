//! Graph SLAM as an anytime task. `run` copies each new LiDAR revolution
//! that should become a keyframe and publishes the map pose every frame;
//! each `step` does one bounded unit of the keyframe's work: move a part of
//! the revolution into the base frame and deskew it with the odometry
//! history, downsample a part, estimate a part's covariances, run a part of
//! a GICP pass, insert the factors, or one Levenberg-Marquardt iteration.
//! A unit visits at most `slam.points_per_step` points.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use speleo_scheduler::realtime::thread_cpu_ns;
use speleo_scheduler::{Context, StepResult, Task};
use speleo_slam::deskew::deskew;
use speleo_slam::graph_slam::{GraphSlam, SlamParams};
use speleo_slam::lie::Pose;

use crate::bus::Bus;
use crate::config::FalseLoopClosure;
use speleo_messages::SlamPose;

/// Points within this span of firing times share one deskewing pose.
const DESKEW_SLICE_S: f64 = 100e-6;

/// A unit of keyframe work this long on the thread's CPU clock is logged
/// (debug), ns.
const SLOW_UNIT_NS: u64 = 1_000_000;

/// Returns closer than this hit the rover itself.
const MIN_RANGE_M: f32 = 0.6;

pub struct SlamTask {
    slam: GraphSlam,
    /// `slam.enabled`: when off, the task publishes the odometry pose.
    enabled: bool,
    /// LiDAR mount: base <- sensor.
    mount: Pose,
    /// Points one step moves into the base frame and deskews.
    points_per_step: usize,
    cloud_seen: u64,
    /// The revolution taken for a keyframe: sensor-frame points and their
    /// times, copied as they came...
    raw: Vec<[f32; 3]>,
    times: Vec<f32>,
    /// Range of each staged point from the sensor.
    ranges: Vec<f32>,
    /// ...and, a part per step, in the base frame at the first firing.
    points: Vec<[f64; 3]>,
    /// When and where the staged revolution began.
    staged: Option<(u64, Pose)>,
    /// Mapping: returns within this range go to the keyframe clouds on the
    /// bus (`None`: no maps), thinned to this many points...
    map_range_m: Option<f32>,
    map_points: usize,
    /// ...from this many in range in the staged revolution.
    staged_in_map_range: usize,
    /// Points of the staged revolution seen so far within the map range.
    map_seen: usize,
    /// The graph changed since the keyframe poses were last published.
    poses_stale: bool,
    /// Revolutions that could not be placed in the odometry history.
    pub scans_without_odometry: u64,
    pub points_not_deskewed: u64,
    /// A wrong loop closure still to inject (fault injection).
    false_loop: Option<FalseLoopClosure>,
}

impl SlamTask {
    pub fn new(p: SlamParams, enabled: bool, mount: Pose, max_cloud_points: usize) -> Self {
        SlamTask {
            ranges: Vec::with_capacity(max_cloud_points),
            map_range_m: None,
            map_points: 0,
            staged_in_map_range: 0,
            map_seen: 0,
            poses_stale: false,
            points_per_step: p.points_per_step.max(1),
            slam: GraphSlam::new(p),
            enabled,
            mount,
            cloud_seen: 0,
            raw: Vec::with_capacity(max_cloud_points),
            times: Vec::with_capacity(max_cloud_points),
            points: Vec::with_capacity(max_cloud_points),
            staged: None,
            scans_without_odometry: 0,
            points_not_deskewed: 0,
            false_loop: None,
        }
    }

    /// Also stage each keyframe's returns within `range_m` (at most
    /// `points`, thinned evenly) into the bus's keyframe clouds, and
    /// publish the keyframe poses after every optimisation, for the maps.
    pub fn with_maps(mut self, range_m: f64, points: usize) -> Self {
        self.map_range_m = Some(range_m as f32);
        self.map_points = points;
        self
    }

    /// Inject this wrong loop closure once both its keyframes exist.
    pub fn inject_false_loop(&mut self, f: FalseLoopClosure) {
        self.false_loop = Some(f);
    }

    /// The injection, when its time has come: SLAM's own estimate of the
    /// relative pose, moved by the configured error, with the information
    /// of the newer keyframe's registration.
    fn inject_due_loop(&mut self) {
        let Some(f) = &self.false_loop else { return };
        if !self.slam.is_idle() || self.slam.keyframes().len() <= f.newer {
            return;
        }
        let rel = self
            .slam
            .keyframe_pose(f.older)
            .between(&self.slam.keyframe_pose(f.newer));
        let error = Pose::new(
            *nalgebra::Rotation3::from_euler_angles(0.0, 0.0, f.yaw_deg.to_radians()).matrix(),
            Vector3::from(f.offset_m),
        );
        let info = self
            .slam
            .registration_information(f.newer)
            .unwrap_or_else(|| nalgebra::Matrix6::identity() * 100.0);
        if self
            .slam
            .add_loop_closure(f.older, f.newer, rel.compose(&error), info)
            .is_ok()
        {
            self.false_loop = None;
        }
    }

    pub fn slam(&self) -> &GraphSlam {
        &self.slam
    }

    /// Stage the newest revolution when it should become a keyframe: only
    /// a copy here, the work is spread over the steps.
    fn take_cloud(&mut self, bus: &mut Bus) {
        let Some(c) = bus.cloud.newer_than(self.cloud_seen) else {
            return;
        };
        self.cloud_seen = c.seq;
        if !self.slam.is_idle() || self.staged.is_some() {
            return;
        }
        let cloud = &c.value;
        // The cloud is stamped when the packet that completed it arrived,
        // which the sensor's clock puts `end_us - start_us` after the first
        // firing (the network's latency, a fraction of a millisecond, is
        // not known here).
        let span_ns = ((cloud.end_us - cloud.start_us).max(0.0) * 1e3) as u64;
        let t0 = c.stamp_ns.saturating_sub(span_ns);
        let Some(odom0) = bus.odom_history.at(t0) else {
            self.scans_without_odometry += 1;
            return;
        };
        let odom0 = Pose::from_isometry(&odom0);
        if !self.slam.wants_keyframe(&odom0) {
            return;
        }
        self.raw.clear();
        self.times.clear();
        self.ranges.clear();
        self.points.clear();
        let slam_range = self.slam.params().max_range_m as f32;
        let range = self.map_range_m.map_or(slam_range, |m| m.max(slam_range));
        self.staged_in_map_range = 0;
        self.map_seen = 0;
        for p in &cloud.points {
            if p.distance < MIN_RANGE_M
                || p.distance > range
                || self.raw.len() == self.raw.capacity()
            {
                continue;
            }
            if self.map_range_m.is_some_and(|m| p.distance <= m) {
                self.staged_in_map_range += 1;
            }
            self.raw.push([p.x, p.y, p.z]);
            self.times.push(p.time);
            self.ranges.push(p.distance);
        }
        if self.map_range_m.is_some() {
            bus.keyframe_clouds.begin();
        }
        self.staged = Some((t0, odom0));
    }

    /// Move the next part of the staged revolution into the base frame and
    /// deskew it; when all of it is done, offer it to SLAM as a keyframe.
    fn deskew_part(&mut self, bus: &mut Bus) {
        let Some((t0, odom0)) = self.staged else {
            return;
        };
        let from = self.points.len();
        let to = (from + self.points_per_step).min(self.raw.len());
        for r in &self.raw[from..to] {
            let v = self
                .mount
                .transform(&Vector3::new(r[0] as f64, r[1] as f64, r[2] as f64));
            self.points.push([v.x, v.y, v.z]);
        }
        let history = &bus.odom_history;
        let slam = &self.slam;
        // The odometry's motion since the first firing, at the distance
        // scale the registrations have measured.
        self.points_not_deskewed += deskew(
            &mut self.points[from..to],
            &self.times[from..to],
            DESKEW_SLICE_S,
            |dt| {
                history
                    .at(t0 + (dt * 1e9) as u64)
                    .map(|iso: Isometry3<f64>| {
                        odom0.compose(
                            &slam.scale_odometry(&odom0.between(&Pose::from_isometry(&iso))),
                        )
                    })
            },
        ) as u64;
        if let Some(m) = self.map_range_m {
            // Even thinning: the j-th point in range is kept when it moves
            // floor(j * kept / in_range) on.
            let (n, keep) = (self.staged_in_map_range, self.map_points);
            for (p, &r) in self.points[from..to].iter().zip(&self.ranges[from..to]) {
                if r > m {
                    continue;
                }
                let j = self.map_seen;
                self.map_seen += 1;
                if n <= keep || (j + 1) * keep / n > j * keep / n {
                    bus.keyframe_clouds.push(*p);
                }
            }
        }
        if to < self.raw.len() {
            return;
        }
        self.staged = None;
        // Gravity in the base frame at the revolution's first firing. The
        // MTi's last sample is up to a revolution late, and a legged rover
        // rocks by degrees within that time; the odometry's attitude is the
        // MTi's roll and pitch carried to any instant by the gyro.
        let up = odom0.r.transpose() * Vector3::z();
        let slam_range = self.slam.params().max_range_m as f32;
        let (points, ranges) = (&self.points, &self.ranges);
        let scan = points
            .iter()
            .zip(ranges)
            .filter(move |(_, &r)| r <= slam_range)
            .map(|(p, _)| *p);
        let taken = self.slam.offer_scan(t0, odom0, up, scan);
        if taken && self.map_range_m.is_some() {
            bus.keyframe_clouds.commit();
        }
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

    fn step(&mut self, bus: &mut Bus, _cx: &Context, quantum: u32) -> StepResult {
        for _ in 0..quantum.max(1) {
            if self.staged.is_some() {
                self.deskew_part(bus);
                continue;
            }
            self.inject_due_loop();
            let checks =
                self.slam.stats().loop_closures + self.slam.stats().loop_candidates_rejected;
            let unheld = self.slam.stats().registrations_unheld;
            // The clock is a system call: read only for the debug log.
            let timed = tracing::enabled!(tracing::Level::DEBUG);
            let (work, cpu0) = (self.slam.work(), if timed { thread_cpu_ns() } else { 0 });
            let busy = self.slam.step();
            let cpu_ns = if timed {
                thread_cpu_ns().saturating_sub(cpu0)
            } else {
                0
            };
            if cpu_ns > SLOW_UNIT_NS {
                // Which unit: the ones that grow with the map show here.
                let (unknowns, factor_nonzeros) = self.slam.system_size();
                tracing::debug!(
                    work,
                    cpu_us = cpu_ns / 1000,
                    keyframes = self.slam.keyframes().len(),
                    unknowns,
                    factor_nonzeros,
                    "slow SLAM unit"
                );
            }
            if !busy {
                if self.poses_stale && self.map_range_m.is_some() {
                    self.poses_stale = false;
                    let slam = &self.slam;
                    bus.keyframe_clouds
                        .set_poses((0..slam.keyframes().len()).map(|k| slam.keyframe_pose(k)));
                }
                return StepResult::Idle;
            }
            self.poses_stale = true;
            let s = self.slam.stats();
            if s.registrations_unheld != unheld {
                if let Some(u) = self.slam.last_unheld() {
                    tracing::debug!(
                        keyframe = self.slam.keyframes().len(),
                        target = u.target,
                        directions = u.directions,
                        surface_share = u.surface_share,
                        "registration kept the guess"
                    );
                }
            }
            if s.loop_closures + s.loop_candidates_rejected != checks {
                if let Some(c) = self.slam.last_loop_check() {
                    tracing::debug!(
                        older = c.older,
                        newer = c.newer,
                        fitness_m = c.fitness_m,
                        inlier_fraction = c.inlier_fraction,
                        iterations = c.iterations,
                        accepted = c.accepted,
                        weakest_info = c.weakest_info,
                        weakest_x = c.weakest_axis[0],
                        weakest_y = c.weakest_axis[1],
                        weakest_z = c.weakest_axis[2],
                        "loop candidate"
                    );
                }
            }
        }
        StepResult::Continue
    }
}
