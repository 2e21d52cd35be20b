//! Graph SLAM as an anytime task. `run` copies each new LiDAR revolution
//! that should become a keyframe and publishes the map pose every frame;
//! each `step` does one bounded unit of the keyframe's work: move a part of
//! the revolution into the base frame and deskew it with the odometry
//! history, downsample a part, estimate a part's covariances, run a part of
//! a GICP pass, insert the factors, or one Levenberg-Marquardt iteration.
//! A unit visits at most `slam.points_per_step` points.

use nalgebra::{UnitQuaternion, Vector3};
use speleo_scheduler::realtime::thread_cpu_ns;
use speleo_scheduler::{Context, StepResult, Task};
use speleo_slam::graph_slam::{GraphSlam, SlamParams};
use speleo_slam::lie::Pose;
use speleo_slam::staging::Stager;

use crate::bus::Bus;
use crate::config::FalseLoopClosure;
use speleo_messages::SlamPose;

/// A unit of keyframe work this long on the thread's CPU clock is logged
/// (debug), ns.
const SLOW_UNIT_NS: u64 = 1_000_000;

pub struct SlamTask {
    slam: GraphSlam,
    /// `slam.enabled`: when off, the task publishes the odometry pose.
    enabled: bool,
    cloud_seen: u64,
    /// The revolution becoming a keyframe.
    pub stager: Stager,
    /// The graph changed since the keyframe poses were last published.
    poses_stale: bool,
    /// A wrong loop closure still to inject (fault injection).
    false_loop: Option<FalseLoopClosure>,
}

impl SlamTask {
    pub fn new(p: SlamParams, enabled: bool, mount: Pose, max_cloud_points: usize) -> Self {
        SlamTask {
            stager: Stager::new(mount, p.points_per_step, max_cloud_points),
            poses_stale: false,
            slam: GraphSlam::new(p),
            enabled,
            cloud_seen: 0,
            false_loop: None,
        }
    }

    /// Also stage each keyframe's returns within `range_m` (at most
    /// `points`, thinned evenly) into the bus's keyframe clouds, and
    /// publish the keyframe poses after every optimisation, for the maps.
    pub fn with_maps(mut self, range_m: f64, points: usize) -> Self {
        self.stager = self.stager.with_maps(range_m, points);
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

    /// Stage the newest revolution when it should become a keyframe.
    fn take_cloud(&mut self, bus: &mut Bus) {
        let Some(c) = bus.cloud.newer_than(self.cloud_seen) else {
            return;
        };
        self.cloud_seen = c.seq;
        // Part of a turn would make a keyframe that sees part of the cave;
        // the next whole turn is a revolution later.
        if !c.value.whole {
            return;
        }
        let history = &bus.odom_history;
        let at = |t: u64| history.at(t);
        let sink = &mut bus.keyframe_clouds;
        self.stager
            .take(&self.slam, &c.value, c.stamp_ns, &at, sink);
    }

    /// The next part of the staged revolution.
    fn deskew_part(&mut self, bus: &mut Bus) {
        let history = &bus.odom_history;
        let at = |t: u64| history.at(t);
        let sink = &mut bus.keyframe_clouds;
        self.stager.deskew_part(&mut self.slam, &at, sink);
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
            if self.stager.is_staged() {
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
                if self.poses_stale && self.stager.maps() {
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
