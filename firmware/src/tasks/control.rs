//! Follows a path with pure pursuit and commands wheel speeds, ramped
//! within the acceleration limits. The rover's pose is the SLAM estimate
//! (the odometry pose corrected by the pose graph; the odometry pose
//! itself while SLAM is off), so the path stays tied to the walls while
//! the odometry drifts.
//!
//! The path is the configured one, or, when following plans (exploration),
//! each plan the planner marks to be driven. On plans the safety monitor
//! checks every command against the serving MLS map, the tilt and the
//! progress, and ends the traverse with a stop when it must; the
//! exploration then replans on fresh maps.

use speleo_control::safety::MonitorInput;
use speleo_control::{
    AccelLimiter, FollowerParams, GroundProbe, PlanFollower, Probe, PurePursuit, SafetyMonitor,
    SkidSteer, StopReason, Twist,
};
use speleo_mapping::mls::{drop_at, ground_near, MlsMap};
use speleo_scheduler::{Context, Task};

use crate::bus::Bus;
use speleo_messages::attitude::{tilt_deg_of, yaw_of};
use speleo_messages::WheelCommand;

/// What the task did on plans.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ControlCounters {
    pub plans_followed: u64,
    /// Plans followed to their end.
    pub plans_completed: u64,
    /// Safety stops by [`StopReason`] code - 1.
    pub stops: [u64; StopReason::ALL.len()],
}

pub struct ControlTask {
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

impl ControlTask {
    pub fn new(
        follower: PurePursuit,
        skid: SkidSteer,
        limiter: AccelLimiter,
        monitor: SafetyMonitor,
    ) -> Self {
        ControlTask {
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
    fn take_plan(&mut self, bus: &Bus) {
        let (Some(plans), Some(plan)) = (&mut self.plans, bus.plan.get().map(|p| &p.value)) else {
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
}

/// Log the cell where the probe that made a map stop looked: its patch
/// count, the lowest patch's top and the highest one's bottom (cm), and
/// whether each was seen from above. Short, whole centimetres: the patch
/// list formatted whole, and then its floats, ran past the log line's
/// buffer, which grew, and the control task allocated after start-up.
fn log_probe_cell(map: &MlsMap, x: f64, y: f64) {
    let cm = |v: f64| (v * 100.0).round() as i32;
    let (ix, iy) = map.cell_of(x, y);
    let cell = map.cell(ix, iy);
    let (Some(lo), Some(hi)) = (cell.first(), cell.last()) else {
        tracing::debug!(x_cm = cm(x), y_cm = cm(y), patches = 0, "safety stop probe");
        return;
    };
    tracing::debug!(
        x_cm = cm(x),
        y_cm = cm(y),
        patches = cell.len(),
        low_top_cm = cm(lo.max.into()),
        low_above = lo.seen_from_above,
        high_bottom_cm = cm(hi.min.into()),
        high_above = hi.seen_from_above,
        "safety stop probe"
    );
}

/// The MLS map as the safety monitor probes it.
pub struct MlsProbe<'a>(pub &'a MlsMap);

/// Height band over the ground that the body sweeps, m: anything in it
/// blocks but a stray return seen from below ([`Patch::stray_from_below`];
/// the planner, which counts every point, draws the next plan).
///
/// [`Patch::stray_from_below`]: speleo_mapping::mls::Patch::stray_from_below
const BODY_BAND_M: (f32, f32) = (0.25, 0.7);

impl GroundProbe for MlsProbe<'_> {
    fn probe(&self, x: f64, y: f64, z: f64, tol_m: f64) -> Probe {
        let (ix, iy) = self.0.cell_of(x, y);
        let cell = self.0.cell(ix, iy);
        let Some(g) = ground_near(cell, z as f32, tol_m as f32) else {
            if drop_at(cell, z as f32, tol_m as f32) {
                return Probe::Drop;
            }
            return Probe::NoGround;
        };
        let (lo, hi) = (g + BODY_BAND_M.0, g + BODY_BAND_M.1);
        if cell
            .iter()
            .any(|p| !p.stray_from_below() && p.max >= lo && p.min <= hi)
        {
            Probe::Blocked
        } else {
            Probe::Ground
        }
    }
}

impl Task<Bus> for ControlTask {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let Some(pose) = bus.slam.get() else {
            return;
        };
        let p = pose.value;
        self.take_plan(bus);
        let dt = self
            .last_run_ns
            .map_or(0.02, |t| (cx.time_ns.saturating_sub(t)) as f64 * 1e-9)
            .min(0.1);
        self.last_run_ns = Some(cx.time_ns);
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
                    t_s: cx.time_ns as f64 * 1e-9,
                    position: p.position,
                    yaw,
                    tilt_deg: tilt_deg_of(p.orientation),
                    v: t.v,
                    w: t.w,
                    remaining_m: plans.remaining_m(x, y),
                    cross_track_m: plans.cross_track_m(x, y),
                    plan_left_m: plans.plan_left_m(x, y),
                };
                let map = bus.surface.serving();
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
        bus.command.publish(
            cx.time_ns,
            WheelCommand {
                speed: v,
                yaw_rate: w,
                wheel_speeds: self.skid.wheel_speeds(v, w),
                segment: self
                    .plans
                    .as_ref()
                    .map_or(self.follower.segment(), PlanFollower::segment)
                    as u32,
                done: self.done(),
                plan: self.following,
                stop: self.stop,
                rim: self.rim,
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

impl ControlTask {
    /// Safety stops by reason.
    pub fn stops(&self) -> impl Iterator<Item = (StopReason, u64)> + '_ {
        StopReason::ALL
            .into_iter()
            .map(|r| (r, self.counters.stops[r as usize - 1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface_maps::SurfaceMaps;
    use crate::tasks::test_context as cx;
    use speleo_control::{AccelLimits, Path, SafetyParams};
    use speleo_mapping::mls::MlsParams;
    use speleo_messages::{PlanMsg, SlamPose};

    /// Ground seen for x in [0, 5), y in [0, 4); nothing beyond (a drop
    /// the LiDAR could not see into).
    fn bus_with_a_ledge() -> Box<Bus> {
        let mut bus = Bus::new();
        bus.surface = SurfaceMaps::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
        let mut pts = Vec::new();
        for i in 0..100 {
            for j in 0..80 {
                pts.push([i as f64 * 0.05 + 0.025, j as f64 * 0.05 + 0.025, 0.0]);
            }
        }
        let m = bus.surface.active();
        bus.surface.map_mut(m).insert_points(&pts);
        bus
    }

    fn task() -> ControlTask {
        ControlTask::new(
            PurePursuit::new(
                FollowerParams {
                    lookahead_m: 0.8,
                    cruise_speed: 0.4,
                    max_yaw_rate: 0.8,
                    goal_tolerance_m: 0.2,
                },
                Path::new(),
                false,
            ),
            SkidSteer {
                wheel_radius_m: 0.19,
                track_width_m: 0.52,
                skid_factor: 1.0,
                max_wheel_speed: 5.0,
            },
            AccelLimiter::new(AccelLimits {
                max_accel: 0.5,
                max_decel: 1.0,
                max_yaw_accel: 2.0,
            }),
            SafetyMonitor::new(SafetyParams::default()),
        )
        .following_plans(FollowerParams {
            lookahead_m: 0.8,
            cruise_speed: 0.4,
            max_yaw_rate: 0.8,
            goal_tolerance_m: 0.2,
        })
    }

    /// Where a driven plan ended.
    struct Ended {
        x: f64,
        yaw: f64,
        command: WheelCommand,
        /// Some command drove backward.
        reversed: bool,
    }

    /// Drive a unicycle with the task's commands from (1, 2) heading +x
    /// along a plan through `poses` until the task reports it done.
    fn drive(bus: &mut Bus, t: &mut ControlTask, poses: impl Iterator<Item = [f32; 4]>) -> Ended {
        let mut plan = PlanMsg {
            query: 1,
            execute: true,
            optimal: true,
            ..PlanMsg::default()
        };
        for p in poses {
            let _ = plan.poses.push(p);
        }
        bus.plan.publish(0, plan);
        let (mut x, mut y, mut yaw) = (1.0, 2.0, 0.0f64);
        let mut reversed = false;
        for f in (1..3000).step_by(2) {
            let q = [(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()];
            bus.slam.publish(
                0,
                SlamPose {
                    position: [x, y, 0.17],
                    orientation: q,
                    keyframes: 1,
                },
            );
            t.run(bus, &cx(f));
            let c = bus
                .command
                .get()
                .unwrap_or_else(|| panic!("no command"))
                .value;
            if c.done {
                return Ended {
                    x,
                    yaw,
                    command: c,
                    reversed,
                };
            }
            reversed |= c.speed < -0.05;
            let dt = 0.02;
            yaw += c.yaw_rate * dt;
            x += c.speed * yaw.cos() * dt;
            y += c.speed * yaw.sin() * dt;
        }
        panic!("the traverse never ended at x = {x}");
    }

    #[test]
    fn the_safety_monitor_stops_the_rover_before_it_leaves_the_map() {
        let mut bus = bus_with_a_ledge();
        let mut t = task();
        // To (9, 2), past the ledge.
        let out = (0..=80).map(|k| [1.0 + 0.1 * k as f32, 2.0, 0.0, 0.0]);
        let Ended { x, command: c, .. } = drive(&mut bus, &mut t, out);
        assert_eq!(c.stop, Some(StopReason::LeavingMap));
        assert_eq!((c.speed, c.yaw_rate), (0.0, 0.0));
        assert_eq!(c.plan, 1);
        // The wheels' front (half the body ahead of base_link) is still
        // over the ground that was seen.
        assert!(x + 0.5 < 5.0 && x > 3.5, "stopped at x = {x}");
        assert_eq!(t.counters.stops[StopReason::LeavingMap as usize - 1], 1);
        // Nothing was seen beyond: a gap, no rim.
        assert_eq!(c.rim, None);
    }

    #[test]
    fn a_stop_before_a_drop_seen_says_where_the_rim_is_until_the_next_plan() {
        let mut bus = bus_with_a_ledge();
        // The floor 2 m under the ledge, seen beyond it.
        let floor: Vec<[f64; 3]> = (0..60)
            .flat_map(|i| (0..80).map(move |j| (i, j)))
            .map(|(i, j)| [5.025 + i as f64 * 0.05, j as f64 * 0.05 + 0.025, -2.0])
            .collect();
        let m = bus.surface.active();
        bus.surface.map_mut(m).insert_points(&floor);
        let mut t = task();
        let out = (0..=80).map(|k| [1.0 + 0.1 * k as f32, 2.0, 0.0, 0.0]);
        let Ended { x, command: c, .. } = drive(&mut bus, &mut t, out);
        assert_eq!(c.stop, Some(StopReason::LeavingMap));
        assert!(x + 0.5 < 5.0, "stopped at x = {x}");
        let rim = c.rim.unwrap_or_else(|| panic!("no rim: {c:?}"));
        assert!(
            rim[0] > 5.0 && rim[0] < 5.5 && (rim[1] - 2.0).abs() < 0.3,
            "{rim:?}"
        );
        // The next plan starts without it.
        let mut next = PlanMsg {
            query: 2,
            execute: true,
            optimal: true,
            ..PlanMsg::default()
        };
        let _ = next.poses.push([1.0, 2.0, 0.0, 0.0]);
        let _ = next.poses.push([2.0, 2.0, 0.0, 0.0]);
        bus.plan.publish(1, next);
        t.run(&mut bus, &cx(9001));
        assert_eq!(bus.command.get().and_then(|c| c.value.rim), None);
    }

    #[test]
    fn a_plan_on_seen_ground_is_driven_to_its_end() {
        let mut bus = bus_with_a_ledge();
        let mut t = task();
        // Out along the ground, then backing up to x = 2.5.
        let out = (0..=20).map(|k| [1.0 + 0.1 * k as f32, 2.0, 0.0, 0.0]);
        let back = (1..=5).map(|k| [3.0 - 0.1 * k as f32, 2.0, 0.0, 0.0]);
        let e = drive(&mut bus, &mut t, out.chain(back));
        assert_eq!(e.command.stop, None);
        assert!(e.reversed, "the last leg is driven backward");
        assert!((e.x - 2.5).abs() < 0.3, "ended at {}", e.x);
        assert!(e.yaw.abs() < 0.1, "it did not turn round: {}", e.yaw);
    }

    #[test]
    fn one_return_from_below_does_not_block_the_body_but_two_or_one_from_above_do() {
        let probe_after = |points: &[[f64; 3]], sensor_z: f64| {
            let mut bus = bus_with_a_ledge();
            let m = bus.surface.active();
            bus.surface
                .map_mut(m)
                .insert_points_seen_from(points, sensor_z);
            MlsProbe(bus.surface.serving()).probe(2.02, 2.02, 0.0, 0.2)
        };
        assert_eq!(probe_after(&[], 0.5), Probe::Ground);
        let one = [[2.02, 2.02, 0.4]];
        assert_eq!(probe_after(&one, 0.0), Probe::Ground, "a stray return");
        assert_eq!(probe_after(&one, 0.6), Probe::Blocked, "seen from above");
        let two = [[2.02, 2.02, 0.4], [2.03, 2.03, 0.42]];
        assert_eq!(probe_after(&two, 0.0), Probe::Blocked, "two returns");
    }
}
