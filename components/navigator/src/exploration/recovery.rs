//! Recovery when no plan is found: retraces along the rover's own track,
//! back-outs from where it was stuck, and the places it remembers (stuck
//! places, slides, rims) that its graphs keep out of their plans.

use speleo_control::StopReason;
use speleo_exploration::ExplorerPhase;
use speleo_mapping::mls::{ground_near, MlsMap};
use speleo_messages::attitude::yaw_of;
use speleo_messages::PlanMsg;
use speleo_physics::quat;
use speleo_simulator::Outcome;

use super::Exploration;
use crate::input::{NavInput, Outbox};

/// A retrace that left the rover within this of where it began got
/// nowhere: the next one from there goes the other way, m.
const RETRACE_HEADWAY_M: f64 = 0.3;

/// Places the rover was stuck at, kept as obstacles (older ones are
/// forgotten first).
pub const MAX_NO_GO: usize = 32;

/// Around a place the rover was stuck at, no path may pass, m: the
/// chassis' half-diagonal, so that what held it (under the body, or under
/// a wheel) is not driven over again.
pub const NO_GO_RADIUS_M: f64 = 0.6;

/// Places the rover slid back or stalled on a slope that are kept (past
/// this many, the oldest goes).
pub const MAX_SLIDES: usize = 16;

/// A stop off the path, without progress or stuck that leaves the rover
/// pitched this much or more is a slide, deg: the slope is more than its
/// wheels hold. The map cannot tell mud from rock: up the lava tube's
/// muddy entrance (18 deg; mud's friction 0.35) the simulation, on
/// rock, passed climb after climb that the rover slid back from at 19-23
/// deg of pitch. The garage's ramps (14 deg) stay below it.
pub const SLIDE_PITCH_DEG: f64 = 17.0;

/// Exploring, no path goes to ground more than `SLIDE_RISE_M` over a
/// slide's place within `SLIDE_RADIUS_M` of it (the slope up from it,
/// across the tube); the way down stays open, m.
pub const SLIDE_RADIUS_M: f64 = 3.0;
pub const SLIDE_RISE_M: f64 = 0.3;

/// Rims kept (past this many, the oldest goes).
pub const MAX_RIMS: usize = 16;

/// Around where the safety monitor saw a drop ahead and stopped the rover,
/// no path goes, m: the front wheels' reach from the centre. The planner's
/// footprint takes cells with nothing seen in them for nothing, and on
/// the garage's roof a rover sent to a goal 0.2 m from two rims was
/// stopped short of one; the next plans, arcs forward (no point turns),
/// took its wheels over the other and turned it over.
pub const RIM_RADIUS_M: f64 = 0.5;

/// After a stuck stop the rover backs this far, m.
const BACK_OUT_M: f64 = 1.0;
/// A retrace's and a back-out's poses lie on the map's ground nearest
/// the rover's within this, m (a drop's floor included).
const GROUND_SEARCH_M: f32 = 2.0;

/// The map's ground at `x, y` nearest `ground_z` (within
/// [`GROUND_SEARCH_M`]), or `ground_z` where the map has none: plan
/// poses are ground heights, and the internal simulation lays its strip
/// of ground along the plan from them. At the rover's own height (its
/// track is base_link's), the strip stood 0.17 m over the holes in the
/// scans and picked up rims that high over the floor: on the lava tube's
/// slope 47 m in, every retrace home tipped the simulated rover at a
/// phantom step, 30 degrees, where the true surface tilts it 25, and the
/// rover was stranded; laid on the ground, the same retraces reach home.
fn ground_at(mls: &MlsMap, x: f64, y: f64, ground_z: f64) -> f64 {
    let (ix, iy) = mls.cell_of(x, y);
    ground_near(mls.cell(ix, iy), ground_z as f32, GROUND_SEARCH_M).map_or(ground_z, f64::from)
}

/// Escapes from a stuck place, in turn: a back-out backward, one forward,
/// a retrace along the track forward, one backward.
const ESCAPE_ROUND: u32 = 4;
/// Retraces refused in a row at one place (each way twice) after which
/// the rover stops retracing there.
const RETRACE_REFUSALS_HERE: u32 = 4;
/// Tilt stops in a row without moving after which the rover is stranded.
pub(crate) const TILT_STALLS_TO_STRAND: u32 = 6;
/// Tilt stops this near each other count as one place, m.
const TILT_STALL_RADIUS_M: f64 = 0.1;

impl Exploration {
    /// A plan ended with `stop`: past the safety monitor's hard tilt limit
    /// no wheel turns, so plan after plan stops where it began (in the
    /// garage a rover hanging off a ramp's side at 42 degrees retraced,
    /// backward and forward, for the rest of the mission). After a few
    /// such stops in one place the rover is stranded and the mission ends.
    pub(crate) fn count_tilt_stall(&mut self, stop: Option<StopReason>, input: &NavInput) {
        let Some(p) = input.slam.map(|p| p.value.position) else {
            return;
        };
        if stop != Some(StopReason::Tilt) {
            self.tilt_stalls = 0;
            return;
        }
        let q = self.last_tilt_stop;
        let same = (p[0] - q[0]).hypot(p[1] - q[1]) < TILT_STALL_RADIUS_M;
        self.tilt_stalls = if same { self.tilt_stalls + 1 } else { 1 };
        self.last_tilt_stop = p;
        if self.tilt_stalls >= TILT_STALLS_TO_STRAND {
            tracing::warn!(
                x = p[0],
                y = p[1],
                z = p[2],
                "stranded: tilted past the limit, no plan moves the rover"
            );
            self.explorer.strand();
        }
    }

    /// A plan ended in a stop at a rim ([`WheelCommand::rim`]): the place
    /// is kept (see [`Exploration::rims`]), once within half
    /// [`RIM_RADIUS_M`].
    ///
    /// [`WheelCommand::rim`]: speleo_messages::WheelCommand::rim
    pub(crate) fn note_rim(&mut self, input: &NavInput) {
        let rim = input.command.and_then(|c| c.value.rim);
        let (Some([x, y]), Some(p)) = (rim, input.slam.map(|p| p.value.position)) else {
            return;
        };
        let at = [x, y, p[2] - self.base_height_m];
        let known = self.rims.iter().any(|q| {
            (q[0] - at[0]).hypot(q[1] - at[1]) < RIM_RADIUS_M / 2.0 && (q[2] - at[2]).abs() < 0.3
        });
        if known {
            return;
        }
        if self.rims.is_full() {
            self.rims.pop_front();
        }
        let _ = self.rims.push_back(at);
        self.counters.rims += 1;
        tracing::debug!(x, y, z = at[2], "stopped at a rim: no path goes near it");
    }

    /// An exploring plan ended with `stop` off the path, without progress
    /// or stuck, the rover pitched [`SLIDE_PITCH_DEG`] or more: the place
    /// is kept as a slide (see [`Exploration::slides`]).
    pub(crate) fn note_slide(&mut self, stop: Option<StopReason>, input: &NavInput) {
        let slid = [
            StopReason::OffPath,
            StopReason::NoProgress,
            StopReason::Stuck,
        ]
        .iter()
        .any(|r| Some(*r) == stop);
        if !slid || self.explorer.phase() != ExplorerPhase::Exploring {
            return;
        }
        let Some(s) = input.slam.map(|p| p.value) else {
            return;
        };
        let (_, pitch, _) = quat::to_ypr(&quat::normalise(&s.orientation));
        if pitch.abs().to_degrees() < SLIDE_PITCH_DEG {
            return;
        }
        let at = [
            s.position[0],
            s.position[1],
            s.position[2] - self.base_height_m,
        ];
        let known = self
            .slides
            .iter()
            .any(|q| (q[0] - at[0]).hypot(q[1] - at[1]) < 0.5 && (q[2] - at[2]).abs() < 0.3);
        if known {
            return;
        }
        if self.slides.is_full() {
            self.slides.pop_front();
        }
        let _ = self.slides.push_back(at);
        self.counters.slides += 1;
        tracing::debug!(
            x = at[0],
            y = at[1],
            z = at[2],
            pitch_deg = pitch.to_degrees(),
            "slid on a slope: the ground up from here is barred for exploring"
        );
    }

    /// A query on the way home found no plan.
    pub fn home_failed(&mut self) {
        self.stranded |= matches!(self.explorer.phase(), ExplorerPhase::Returning(_));
    }

    /// A query found no ground to start from under the rover, or nothing
    /// to explore from where it stands (the graph may be hemmed in: a way
    /// the rover came that the map has since come to refuse).
    pub fn no_start(&mut self) {
        self.stranded = true;
    }

    pub fn retrace_due(&self) -> bool {
        self.stranded
            && !matches!(
                self.explorer.phase(),
                ExplorerPhase::Finished(_) | ExplorerPhase::Stranded
            )
    }

    /// Drive back along the rover's own track, `ahead_m` of it, as plan
    /// `query`: the rover came this way, so it can go back. The map may
    /// have come to refuse the way (a low rim seen from the far side, a
    /// gap the planner no longer bridges); the safety monitor still
    /// watches every metre of it. With the internal simulator the
    /// retrace is only shown, and true returned: it is driven once the
    /// simulation passes it ([`Exploration::driving`]). So is a back-out
    /// ([`Exploration::back_out_passed`]), judged more leniently.
    pub fn retrace(
        &mut self,
        input: &NavInput,
        out: &mut Outbox,
        query: u64,
        ahead_m: f64,
    ) -> bool {
        self.stranded = false;
        if core::mem::take(&mut self.back_out) {
            // A back-out each way got nowhere: the track next, steered,
            // forward then backward. A rover wedged on a rock pivots on it
            // under straight back-outs (the lava tube's rover did so for a
            // quarter of an hour, 77 m in), where the follower, turning it
            // onto its track, drove it off.
            let round = self.escape_attempts % ESCAPE_ROUND;
            self.escape_attempts += 1;
            if round < 2 {
                return self.back_out(input, out, query, round == 1);
            }
        }
        self.backing_out = false;
        self.counters.retraces += 1;
        let Some((pose, yaw)) = input.slam.map(|p| {
            let yaw = yaw_of(p.value.orientation);
            (p.value.position, yaw)
        }) else {
            return false;
        };
        // Exploring, back the way the rover came; going home, back along
        // the track from its first pass here, which leads home (from the
        // last pass, it led back out the way the rover had just come
        // home by).
        let track = self.explorer.trail();
        let trail = track.points();
        let from = if matches!(self.explorer.phase(), ExplorerPhase::Returning(_)) {
            track.earliest_near(pose, 2.0)
        } else {
            track.latest_near(pose, 2.0)
        };
        let Some(mut from) = from else {
            return false;
        };
        // Not past a point the rover has come back from: after a slide
        // back down a slope (or a back-out) the latest point near it lies
        // ahead of it, and the retrace drove up to it and turned round
        // there (the lava tube's muddy entrance: up 0.8 m, then a 170°
        // turn at 20° of pitch, or a spin on the spot to back up to it).
        let away = |p: &[f64; 3]| (p[0] - pose[0]).hypot(p[1] - pose[1]);
        while from > 0 && away(&trail[from - 1]) < away(&trail[from]) {
            from -= 1;
        }
        let validate = self.validates();
        let mut msg = PlanMsg {
            query,
            execute: !validate,
            ..PlanMsg::default()
        };
        let mut at = pose;
        let mut left = ahead_m;
        let mut points = [[0.0f64; 3]; 64];
        let mut n = 0;
        points[n] = pose;
        n += 1;
        for p in trail[..=from].iter().rev() {
            if n == points.len() || left <= 0.0 {
                break;
            }
            let d = (p[0] - at[0]).hypot(p[1] - at[1]);
            if d < 0.05 {
                // Where the rover stands: no direction to it.
                continue;
            }
            left -= d;
            points[n] = *p;
            n += 1;
            at = *p;
        }
        // Driven forward, the rover turning round where it must. When the
        // last retrace began here and got nowhere, the other way: in a
        // mesh world's junction, turning round onto the track tilted the
        // rover on a rim, stop after stop for the rest of the mission.
        // (Backward every time, the lava tube's rover tilted backing down
        // a slope it had driven up.) Stopped short of ground it could not
        // see, facing the way the rover faces: no turn where the ground
        // ends (stopped so at the garage's first ramp's top, the rover
        // backed down it, and went on to the roof; turning round there,
        // it never reached the roof).
        let again_here = self
            .retraced_from
            .filter(|(p, _)| (p[0] - pose[0]).hypot(p[1] - pose[1]) < RETRACE_HEADWAY_M);
        let next = points[1.min(n - 1)];
        let first_leg = (next[1] - pose[1]).atan2(next[0] - pose[0]);
        // The track's own way, from its first point to the next: the leg
        // from the pose turns with every jump of the pose (at garage seed
        // 2's roof rim a loop closure moved it 0.4 m, the first leg read
        // 60° off the yaw, the rover drove forward, turned into the rim
        // and tipped). The first leg only when the track has one point.
        let track_way = if n >= 3 {
            (points[2][1] - next[1]).atan2(points[2][0] - next[0])
        } else {
            first_leg
        };
        let backward = match again_here {
            Some((_, b)) => !b,
            None => self.last_stop == Some(StopReason::LeavingMap) && (yaw - track_way).cos() < 0.0,
        };
        if again_here.is_none() {
            self.refused_here = 0;
        }
        self.retraced_from = Some((pose, backward));
        let turn = if backward { core::f64::consts::PI } else { 0.0 };
        for i in 0..n {
            let (a, b) = (points[i], points[(i + 1).min(n - 1)]);
            let along = if i + 1 < n {
                (b[1] - a[1]).atan2(b[0] - a[0])
            } else {
                let p = points[i.saturating_sub(1)];
                (a[1] - p[1]).atan2(a[0] - p[0])
            };
            let heading = (along + turn + core::f64::consts::PI).rem_euclid(core::f64::consts::TAU)
                - core::f64::consts::PI;
            let z = ground_at(input.map, a[0], a[1], a[2] - self.base_height_m);
            let _ = msg
                .poses
                .push([a[0] as f32, a[1] as f32, z as f32, heading as f32]);
        }
        tracing::debug!(
            x = pose[0],
            y = pose[1],
            to_x = points[n - 1][0],
            to_y = points[n - 1][1],
            // What the facing rule saw (at a garage roof's rim it drove
            // forward after a stop there, and why was not known).
            next_x = next[0],
            next_y = next[1],
            yaw_deg = yaw.to_degrees(),
            first_leg_deg = first_leg.to_degrees(),
            track_way_deg = track_way.to_degrees(),
            last_stop = self.last_stop.map_or("none", StopReason::name),
            backward,
            "retracing"
        );
        if !validate {
            self.executing = query;
            self.counters.plans_executed += 1;
        }
        out.status.goal = Some(points[n - 1]);
        out.publish(msg);
        validate
    }

    /// The simulation refused the retrace shown: nothing is driven, and
    /// the next query retraces again (the other way, from here). After
    /// [`RETRACE_REFUSALS_HERE`] refusals in a row at one place, exploring
    /// goes home by plans; on the way home, the rover is stranded. (In the
    /// garage, refused retraces on a ramp, each tried again at once the
    /// other way, burned the rest of the mission: 1,337 of them.)
    pub fn retrace_refused(&mut self) {
        self.counters.retraces_refused += 1;
        self.stranded = true;
        self.refused_here += 1;
        if self.refused_here < RETRACE_REFUSALS_HERE {
            return;
        }
        self.refused_here = 0;
        self.stranded = false;
        let at = self.retraced_from.map_or([f64::NAN; 3], |(p, _)| p);
        if self.explorer.give_up_here([at[0], at[1]]) {
            tracing::info!(
                x = at[0],
                y = at[1],
                "every retrace refused here: home by plans"
            );
        } else {
            tracing::warn!(
                x = at[0],
                y = at[1],
                "stranded: every retrace home refused by the simulation"
            );
            self.explorer.strand();
        }
    }

    /// Get off what held the rover: straight along its body axis, without
    /// turning (a rover sitting on a rock pivots on it when it turns),
    /// backward first and, when that fails too, forward, and so on. With
    /// the internal simulator it is only shown, and true returned (see
    /// [`Exploration::back_out_passed`]).
    pub(crate) fn back_out(
        &mut self,
        input: &NavInput,
        out: &mut Outbox,
        query: u64,
        forward: bool,
    ) -> bool {
        let Some(p) = input.slam.map(|p| p.value) else {
            return false;
        };
        self.counters.backed_out += 1;
        self.backing_out = true;
        let yaw = yaw_of(p.orientation);
        let sign = if forward { -1.0 } else { 1.0 };
        tracing::debug!(
            x = p.position[0],
            y = p.position[1],
            backward = sign > 0.0,
            "backing out"
        );
        let validate = self.validates();
        let mut msg = PlanMsg {
            query,
            execute: !validate,
            ..PlanMsg::default()
        };
        const STEPS: usize = 5;
        let ground = p.position[2] - self.base_height_m;
        for k in 0..=STEPS {
            let d = -sign * BACK_OUT_M * k as f64 / STEPS as f64;
            let (x, y) = (p.position[0] + d * yaw.cos(), p.position[1] + d * yaw.sin());
            // At the rover's ground height the strip would bridge a drop.
            let z = ground_at(input.map, x, y, ground);
            let _ = msg.poses.push([x as f32, y as f32, z as f32, yaw as f32]);
        }
        if !validate {
            self.back_out_passed(query);
        }
        // No goal: a back-out stopped on its way rejects no candidate.
        out.status.goal = None;
        out.publish(msg);
        validate
    }

    /// The plan shown is a back-out.
    pub fn backing_out(&self) -> bool {
        self.backing_out
    }

    /// Whether the simulation's `outcome` lets the back-out shown be
    /// driven. Not whether it gets free: what holds the rover is what
    /// the map does not show (the real rover stuck where the simulated
    /// one drove), so a simulated rover stuck or short of the end passes.
    /// But a back-out that tilts it past the limit or off the ground does
    /// not: in the garage a blind back-out from a turn stuck on a ramp
    /// went down the ramp's side to 30 degrees of tilt, and no plan moved
    /// the rover from there.
    pub fn back_out_passes(outcome: Outcome) -> bool {
        !matches!(
            outcome,
            Outcome::TippedOver | Outcome::NoGround | Outcome::Fell
        )
    }

    /// The back-out, passed or not validated, is driven as plan `query`.
    pub fn back_out_passed(&mut self, query: u64) {
        self.executing = query;
        self.counters.plans_executed += 1;
    }

    /// The simulation refused the back-out shown: nothing is driven, and
    /// the next query tries the next escape (the other way, then the
    /// track).
    pub fn back_out_refused(&mut self) {
        self.counters.back_outs_refused += 1;
        self.backing_out = false;
        self.back_out = true;
        self.stranded = true;
    }

    /// Nothing is left to explore, but places were barred on the way
    /// (no-go discs where the rover was stuck, goals it was stopped on the
    /// way to or had no plan to): once a mission, forget them and explore
    /// on. In a narrow tube one stuck place bars the way on for good, and
    /// the stop may have been bad luck (a wheel on a rock's flank) more
    /// than the place. True when the look is taken now.
    pub fn second_look(&mut self) -> bool {
        let barred = !self.no_go.is_empty() || !self.explorer.rejected().is_empty();
        if self.second_look_taken || !barred {
            return false;
        }
        self.second_look_taken = true;
        self.no_go.clear();
        self.explorer.forget_rejected();
        // Nothing is barred now: resumed wherever the rover is.
        let home = self.explorer.home();
        self.explorer.resume([home[0], home[1]]);
        self.counters.second_looks += 1;
        tracing::debug!("a second look, the barred places forgotten");
        true
    }
}
