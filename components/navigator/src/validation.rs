//! The internal simulation's part in a query: every exploring plan, retrace
//! and back-out is driven there before it is marked to be driven, and a
//! refused plan's well-driven first part may be driven instead.

use speleo_exploration::ExplorerPhase;
use speleo_messages::attitude::yaw_of;
use speleo_messages::{PlanMsg, SlamPose};
use speleo_simulator::{Outcome, Stance};

use crate::exploration::Exploration;
use crate::input::{Clouds, NavInput, Outbox};
use crate::query::{Phase, Query};
use crate::rehearsal::Rehearsal;
use crate::Navigator;

impl Navigator {
    /// No goal of the query passed the simulation, but a refused plan's
    /// first part was driven well: drive that.
    pub(crate) fn drive_partial(&mut self, _now: u64) {
        let Some(ex) = self.explore.as_deref_mut() else {
            self.end_query();
            return;
        };
        ex.counters.partial_plans += 1;
        tracing::debug!(
            length_m = ex.partial.length_m,
            goal_x = ex.partial.goal[0],
            goal_y = ex.partial.goal[1],
            "driving the part of a refused plan the simulation drove"
        );
        let msg = PlanMsg {
            query: self.counters.queries,
            cost_ms: 0,
            eps: self.query.eps_milli as f32 / 1000.0,
            optimal: false,
            execute: true,
            poses: ex.partial.poses.clone(),
        };
        self.counters.plans_published += 1;
        ex.driving(msg.query);
        ex.compare_partial(msg.query);
        self.out.status.goal = ex
            .partial
            .poses
            .last()
            .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64]);
        self.out.publish(msg);
        self.end_query();
    }

    /// Exploring, the query's plan is final: drive it, or first drive it in
    /// the internal simulator.
    pub(crate) fn plan_found(
        &mut self,
        input: &NavInput,
        host: &mut dyn Rehearsal,
        best: (u32, u32),
        optimal: bool,
    ) {
        let validate = self.explore.as_ref().is_some_and(|e| e.validates());
        // Shown while it is validated; marked to be driven otherwise.
        self.publish(best, optimal, !validate);
        if self.explore.is_none() {
            return;
        }
        self.query.best = (best, optimal);
        if !self.simulate_shown_plan(input, host) {
            self.end_query();
        }
    }

    /// The retrace just shown is driven in the internal simulator first,
    /// as every plan is: a blind one turned the garage's rover round at
    /// the roof's ramp opening until it hung tilted over the edge.
    pub(crate) fn validate_retrace(
        &mut self,
        input: &NavInput,
        host: &mut dyn Rehearsal,
        pose: &SlamPose,
    ) -> bool {
        let now = input.now_ns;
        self.query = Query {
            began_ns: now,
            rover: pose.position,
            yaw: yaw_of(pose.orientation),
            attitude: pose.orientation,
            retrace: true,
            ..Query::default()
        };
        self.simulate_shown_plan(input, host)
    }

    /// Begin driving the plan shown on the bus in the internal simulator
    /// from the query's pose (the `Validate` phase); false without a
    /// simulator or a plan.
    pub(crate) fn simulate_shown_plan(
        &mut self,
        input: &NavInput,
        host: &mut dyn Rehearsal,
    ) -> bool {
        let now = input.now_ns;
        let Some(ex) = self.explore.as_deref_mut() else {
            return false;
        };
        // Exploring plans only: a retrace goes back the way the rover
        // came, and home is where it must go anyway.
        let way_back = !self.query.retrace && ex.phase() == ExplorerPhase::Exploring;
        let (Some(sim), Some(plan)) = (ex.sim_home(host), self.out.shown()) else {
            return false;
        };
        let start = Stance::from_quat(self.query.rover, self.query.attitude);
        let mut poses = plan
            .poses
            .iter()
            .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64, p[3] as f64]);
        sim.begin(start, poses.clone());
        if way_back {
            sim.check_way_back();
        }
        if let Some(d) = host.record() {
            // Stamped with the pose's time: a query's later goals start
            // from the pose its first began with.
            d.begin(self.query.began_ns, start, way_back, &mut poses);
        }
        ex.validation_began_ns = now;
        // The old world's teardown needs no clouds: on the worker already.
        ex.sim_lend(host);
        self.phase = Phase::Validate;
        true
    }

    /// A slice of the internal simulation; at its verdict, the plan is
    /// driven or the next goal is tried. With a worker, the batch it did
    /// since the last frame is taken back, the clouds' integration done
    /// here, and the rest lent to it again.
    pub(crate) fn validate(&mut self, input: &NavInput, units: usize, host: &mut dyn Rehearsal) {
        let now = input.now_ns;
        let Some(ex) = self.explore.as_deref_mut() else {
            self.end_query();
            return;
        };
        let offloaded = host.offloads();
        let Some(sim) = ex.sim_home(host) else {
            self.end_query();
            return;
        };
        let verdict = if !offloaded || sim.needs_clouds() {
            let clouds = Clouds(input.clouds);
            match host.record() {
                Some(d) => {
                    let keep = sim.read_region();
                    let rec = speleo_simulator::RecordingClouds {
                        inner: &clouds,
                        case: d.case(),
                        keep,
                    };
                    sim.step(&rec, units)
                }
                None => sim.step(&clouds, units),
            }
        } else {
            sim.verdict()
        };
        let Some(v) = verdict else {
            ex.sim_lend(host);
            return;
        };
        // Where the simulated rover ended (a tip-over before the first
        // sample leaves the prediction empty).
        let end = sim
            .rover_state()
            .map(|b| b.position)
            .or_else(|| sim.prediction().last().copied())
            .unwrap_or([f64::NAN; 3]);
        ex.record_verdict(v.outcome, now);
        if let Some(d) = host.record() {
            d.finish(ex.counters.validations, v);
        }
        tracing::debug!(outcome = ?v.outcome, drive_s = v.drive_s, goal_error_m = v.goal_error_m, start_z = self.query.rover[2], end_x = end[0], end_y = end[1], end_z = end[2], retrace = self.query.retrace, "simulated");
        if self.query.retrace && ex.backing_out() {
            let query = self.counters.queries;
            if Exploration::back_out_passes(v.outcome) {
                drive_shown_plan(&mut self.out);
                ex.back_out_passed(query);
            } else {
                tracing::debug!(outcome = ?v.outcome, "back-out refused");
                ex.back_out_refused();
            }
            self.end_query();
            return;
        }
        if self.query.retrace {
            let query = self.counters.queries;
            if v.success() {
                drive_shown_plan(&mut self.out);
                ex.driving(query);
                ex.compare_next(query);
            } else {
                ex.retrace_refused();
            }
            self.end_query();
            return;
        }
        if v.success() {
            let (best, optimal) = self.query.best;
            self.publish(best, optimal, true);
            if let Some(ex) = self.explore.as_deref_mut() {
                ex.compare_next(ex.executing);
            }
            self.end_query();
            return;
        }
        let at = self.query.order[self.query.tried].1;
        if ex.phase() == ExplorerPhase::Exploring {
            ex.explorer.reject([at[0], at[1]]);
            // A tip-over's or a fall's run-up is no ground to stop on; a
            // plan without a way back was driven whole.
            if !matches!(
                v.outcome,
                Outcome::TippedOver | Outcome::Fell | Outcome::NoWayBack | Outcome::TooSteepForGrip
            ) {
                if let Some(plan) = self.out.shown() {
                    ex.offer_partial(&plan.poses, at);
                }
            }
        }
        self.phase = self.try_goal(self.query.tried + 1);
    }
}

/// The plan shown last (a retrace or a back-out the simulation
/// passed), marked to be driven.
fn drive_shown_plan(out: &mut Outbox) {
    if let Some(p) = out.shown() {
        let mut msg = p.clone();
        msg.execute = true;
        out.publish(msg);
    }
}
