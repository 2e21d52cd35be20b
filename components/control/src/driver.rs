//! The driver: follows a path with pure pursuit and commands wheel
//! speeds, ramped within the acceleration limits. The rover's pose is the
//! SLAM estimate, so the path stays tied to the walls while the odometry
//! drifts.
//!
//! The path is the configured one, or, when following plans (exploration),
//! each plan the planner marks to be driven. On plans the safety monitor
//! checks every command against the serving MLS map, the tilt and the
//! progress, and ends the traverse with a stop when it must; the
//! exploration then replans on fresh maps.

use speleo_mapping::mls::MlsMap;
use speleo_messages::attitude::{tilt_deg_of, yaw_of};
use speleo_messages::{PlanMsg, SlamPose, WheelCommand};

use crate::mls_probe::{log_probe_cell, MlsProbe};
use crate::safety::MonitorInput;
use crate::{
    AccelLimiter, FollowerParams, PlanFollower, PurePursuit, SafetyMonitor, SkidSteer, StopReason,
    Twist,
};

/// What the driver did on plans.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ControlCounters {
    pub plans_followed: u64,
    /// Plans followed to their end.
    pub plans_completed: u64,
    /// Safety stops by [`StopReason`] code - 1.
    pub stops: [u64; StopReason::ALL.len()],
}

pub struct Driver {
    /// The configured path.
    follower: PurePursuit,
    /// The plans, when following plans (exploration).
    plans: Option<PlanFollower>,
    skid: SkidSteer,
    limiter: AccelLimiter,
    monitor: SafetyMonitor,
    /// The plan being followed (0: none yet).
    following: u64,
    stop: Option<StopReason>,
    /// Where the stop's probe saw a drop (see [`WheelCommand::rim`]).
    rim: Option<[f64; 2]>,
    last_run_ns: Option<u64>,
    /// Reduced mode: half speed.
    degraded: bool,
    pub counters: ControlCounters,
}

impl Driver {
    pub fn new(
        follower: PurePursuit,
        skid: SkidSteer,
        limiter: AccelLimiter,
        monitor: SafetyMonitor,
    ) -> Self {
        Driver {
            follower,
            plans: None,
            skid,
            limiter,
            monitor,
            following: 0,
            stop: None,
            rim: None,
            last_run_ns: None,
            degraded: false,
            counters: ControlCounters::default(),
        }
    }

    /// Follow the planner's plans (exploration) instead of the configured
    /// path, with the configured path's follower settings.
    pub fn following_plans(mut self, p: FollowerParams) -> Self {
        self.plans = Some(PlanFollower::new(p));
        self
    }

    /// Take a new plan to drive, if the planner has marked one.
    fn take_plan(&mut self, plan: Option<&PlanMsg>) {
        let (Some(plans), Some(plan)) = (&mut self.plans, plan) else {
            return;
        };
        if !plan.execute || plan.query <= self.following {
            return;
        }
        self.following = plan.query;
        self.stop = None;
        self.rim = None;
        self.monitor.reset();
        self.counters.plans_followed += 1;
        let poses = plan
            .poses
            .iter()
            .map(|p| [p[0] as f64, p[1] as f64, p[3] as f64]);
        if !plans.set_plan(poses) {
            // Already there.
            self.counters.plans_completed += 1;
        }
    }

    /// The command, and whether the path or plan had already ended.
    fn command(&mut self, x: f64, y: f64, yaw: f64) -> (Twist, bool) {
        match &mut self.plans {
            Some(p) => {
                let was_done = p.done();
                (p.command(x, y, yaw), was_done)
            }
            None => (self.follower.command(x, y, yaw), self.follower.done()),
        }
    }

    fn done(&self) -> bool {
        self.plans
            .as_ref()
            .map_or(self.follower.done(), PlanFollower::done)
    }

    /// One control step at `now_ns` from `pose` on `map`, with `plan` the
    /// planner's newest plan: the wheel command.
    pub fn step(
        &mut self,
        now_ns: u64,
        pose: &SlamPose,
        plan: Option<&PlanMsg>,
        map: &MlsMap,
    ) -> WheelCommand {
        let p = *pose;
        self.take_plan(plan);
        let dt = self
            .last_run_ns
            .map_or(0.02, |t| (now_ns.saturating_sub(t)) as f64 * 1e-9)
            .min(0.1);
        self.last_run_ns = Some(now_ns);
        let [x, y, _] = p.position;
        let yaw = yaw_of(p.orientation);
        let (mut t, was_done) = self.command(x, y, yaw);
        if self.degraded {
            t.v *= 0.5;
            t.w *= 0.5;
        }
        let following = self.following != 0;
        if let (Some(plans), true) = (&mut self.plans, following && !was_done) {
            if plans.done() {
                self.counters.plans_completed += 1;
            } else {
                let input = MonitorInput {
                    t_s: now_ns as f64 * 1e-9,
                    position: p.position,
                    yaw,
                    tilt_deg: tilt_deg_of(p.orientation),
                    v: t.v,
                    w: t.w,
                    remaining_m: plans.remaining_m(x, y),
                    cross_track_m: plans.cross_track_m(x, y),
                    plan_left_m: plans.plan_left_m(x, y),
                };
                if let Some(r) = self.monitor.check(&input, &MlsProbe(map)) {
                    if let Some([px, py]) = self.monitor.trigger() {
                        log_probe_cell(map, px, py);
                    }
                    tracing::debug!(
                        reason = r.name(),
                        x = p.position[0],
                        y = p.position[1],
                        z = p.position[2],
                        yaw_deg = yaw.to_degrees(),
                        tilt_deg = input.tilt_deg,
                        v = t.v,
                        w = t.w,
                        "safety stop"
                    );
                    self.stop = Some(r);
                    self.rim = self
                        .monitor
                        .trigger()
                        .filter(|_| r == StopReason::LeavingMap && self.monitor.trigger_saw_drop());
                    self.counters.stops[r as usize - 1] += 1;
                    plans.abandon();
                    // A safety stop does not ramp.
                    self.limiter.halt();
                    t.v = 0.0;
                    t.w = 0.0;
                }
            }
        }
        let (v, w) = self.limiter.step(t.v, t.w, dt);
        WheelCommand {
            speed: v,
            yaw_rate: w,
            wheel_speeds: self.skid.wheel_speeds(v, w),
            segment: self
                .plans
                .as_ref()
                .map_or(self.follower.segment(), PlanFollower::segment) as u32,
            done: self.done(),
            plan: self.following,
            stop: self.stop,
            rim: self.rim,
        }
    }

    /// Reduced mode (half speed) or not.
    pub fn set_degraded(&mut self, degraded: bool) {
        self.degraded = degraded;
    }

    /// Safety stops by reason.
    pub fn stops(&self) -> impl Iterator<Item = (StopReason, u64)> + '_ {
        StopReason::ALL
            .into_iter()
            .map(|r| (r, self.counters.stops[r as usize - 1]))
    }
}
