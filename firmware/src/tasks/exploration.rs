//! The exploration behaviour inside the planner task: when a traverse is
//! over and the maps have settled, a query grows the graph, scans it for
//! candidates and plans to them in turn; the first plan found is handed to
//! the control task to drive. When nothing is left, or time is up, the
//! goals come from the rover's track home instead.

use speleo_control::StopReason;
use speleo_exploration::{
    CandidateParams, CandidateScan, EnergyMeter, Explorer, ExplorerParams, Mode,
};
use speleo_mapping::mls::ground_near;
use speleo_simulator::{
    driven_prefix, rmse_at_equal_times, InternalSim, Outcome, Prefix, PrefixRule, PREDICTION_POINTS,
};

use crate::tasks::sim_worker::SimWorker;
use crate::validation_dump::ValidationDump;
use speleo_hal::cia402;
use speleo_physics::quat;
use speleo_slam::lie::Pose;

use crate::bus::Bus;
use speleo_messages::{ExplorationPhase, ExplorationStatus, PlanMsg, PLAN_POSES};

/// What the exploration did, for the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExplorationCounters {
    /// Queries that scanned for candidates, and those that found none.
    pub scans: u64,
    pub scans_empty: u64,
    /// Goals planned to (candidates and points home), and those with no path.
    pub goals_attempted: u64,
    pub goals_unreachable: u64,
    /// Goals refused before planning for a rock under the body there.
    pub goals_on_rocks: u64,
    /// Plans handed to the control task.
    pub plans_executed: u64,
    /// Queries that found no plan from where the rover stood (going home)
    /// or no ground under it, after which it drove back along its own
    /// track.
    pub retraces: u64,
    /// Retraces the internal simulation refused (not driven).
    pub retraces_refused: u64,
    /// Returns home that found something explorable on the way and went
    /// back to exploring.
    pub resumes: u64,
    /// Stuck stops after which the rover backed out (straight, backward
    /// or forward) and the place became an obstacle for the planner.
    pub backed_out: u64,
    /// Back-outs the internal simulation refused (not driven): they
    /// tilted the simulated rover past the limit or left the ground.
    pub back_outs_refused: u64,
    /// Times nothing was left but barred places, which were forgotten
    /// to explore on (once a mission).
    pub second_looks: u64,
    /// Places the rover slid back or stalled climbing a slope, from which
    /// the ground up is barred for exploring (see [`SLIDE_PITCH_DEG`]).
    pub slides: u64,
    /// Rims the safety monitor stopped the rover at (a drop seen ahead),
    /// around which no path goes from then on (see [`RIM_RADIUS_M`]).
    pub rims: u64,
    /// Plans driven in the internal simulator, those it passed and those
    /// it refused (by outcome: timeout, tip-over, stuck, missed, no ground,
    /// no way back, overhang, fall).
    pub validations: u64,
    pub validated: u64,
    pub rejected_by_sim: u64,
    pub sim_outcomes: [u64; 8],
    pub sim_physics_steps: u64,
    pub sim_triangles_max: u64,
    /// Refused plans whose first part, the part the simulated rover drove
    /// well, was driven when no goal of the query passed (see
    /// [`Partial`]).
    pub partial_plans: u64,
}

/// A retrace that left the rover within this of where it began got
/// nowhere: the next one from there goes the other way, m.
const RETRACE_HEADWAY_M: f64 = 0.3;
/// Results kept for the report's medians.
const HISTORY: usize = 8192;

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
fn ground_at(bus: &Bus, x: f64, y: f64, ground_z: f64) -> f64 {
    let mls = bus.surface.serving();
    let (ix, iy) = mls.cell_of(x, y);
    ground_near(mls.cell(ix, iy), ground_z as f32, GROUND_SEARCH_M).map_or(ground_z, f64::from)
}

/// The longest well-driven first part of the plans the simulation refused
/// in one query ([`speleo_simulator::driven_prefix`]): the rover drives it
/// when no goal of the query passes. A garage ramp seen from the level
/// under it is ground up to the sensor's height and an underside beyond,
/// where the simulated rover stalls; from partway up, the rest is seen.
pub struct Partial {
    pub poses: heapless::Vec<[f32; 4], PLAN_POSES>,
    /// The prediction up to the last pose.
    pub predicted: Vec<[f64; 3]>,
    pub length_m: f64,
    /// The refused goal it was on the way to.
    pub goal: [f64; 3],
}

impl Partial {
    pub fn clear(&mut self) {
        self.poses.clear();
        self.predicted.clear();
        self.length_m = 0.0;
    }

    /// Keep `prefix` of `plan` (and of `prediction`) if it is longer than
    /// the one kept.
    pub fn offer(
        &mut self,
        plan: &[[f32; 4]],
        prediction: &[[f64; 3]],
        prefix: Prefix,
        goal: [f64; 3],
    ) {
        if prefix.length_m <= self.length_m {
            return;
        }
        self.clear();
        for q in &plan[..prefix.poses.min(plan.len())] {
            let _ = self.poses.push(*q);
        }
        let n = prefix.samples.min(prediction.len()).min(PREDICTION_POINTS);
        self.predicted.extend_from_slice(&prediction[..n]);
        self.length_m = prefix.length_m;
        self.goal = goal;
    }
}

/// The executed track of a validated plan, sampled like the prediction.
struct Comparison {
    query: u64,
    predicted: Vec<[f64; 3]>,
    executed: Vec<[f64; 3]>,
    /// Motion began at this time; the next sample is due then.
    moving_since: Option<u64>,
    next_sample_ns: u64,
    active: bool,
}

impl Comparison {
    /// Follow plan `query` against the prediction now held.
    fn begin(&mut self, query: u64) {
        self.query = query;
        self.executed.clear();
        self.moving_since = None;
        self.active = true;
    }
}

pub struct Exploration {
    pub explorer: Explorer,
    pub scan: CandidateScan,
    pub target: Option<[f64; 2]>,
    settle_ns: u64,
    /// The first SLAM pose has become home.
    homed: bool,
    /// The query whose plan the control task was given (0: none yet).
    pub executing: u64,
    /// Since when the control task has been seen idle.
    idle_since: Option<u64>,
    last_observed: [f64; 2],
    pub counters: ExplorationCounters,
    /// The internal simulator, when plans are validated first (`None`
    /// while a batch is out on the worker); the LiDAR mount (base <-
    /// sensor) for the keyframe clouds.
    pub sim: Option<Box<InternalSim>>,
    /// The core of its own the simulator does most of its work on.
    pub worker: Option<SimWorker>,
    /// Every validation's inputs written to files (`[simulator] dump_dir`).
    pub dump: Option<ValidationDump>,
    pub mount: Pose,
    /// When the validation under way began.
    pub validation_began_ns: u64,
    comparison: Comparison,
    pub partial: Partial,
    partial_scratch: Vec<[f64; 4]>,
    /// Per validation: mission time it took, ms; per compared traverse:
    /// the RMSE between predicted and executed positions, m.
    pub validation_ms: Vec<u32>,
    pub prediction_rmse_m: Vec<f64>,
    /// The last query found no plan from where the rover stands (no
    /// ground under it, or on the way home no path).
    stranded: bool,
    /// Highest and lowest the rover has been over home (SLAM), m.
    pub climbed_m: f64,
    pub descended_m: f64,
    /// Where the rover was stuck: obstacles in every graph from then on.
    pub no_go: heapless::Deque<[f64; 3], MAX_NO_GO>,
    /// Where the rover slid on a slope (ground under it): the ground up
    /// from there is barred in exploring graphs. Not cleared by the second
    /// look, unlike `no_go`: the slope is what it is (only the oldest goes
    /// past [`MAX_SLIDES`]).
    pub slides: heapless::Deque<[f64; 3], MAX_SLIDES>,
    /// Where the safety monitor saw a drop ahead (x, y, and the rover's
    /// ground there): obstacles within [`RIM_RADIUS_M`] in every graph.
    /// Kept like slides: a rim is what it is.
    pub rims: heapless::Deque<[f64; 3], MAX_RIMS>,
    /// The next retrace backs out of a place the rover was stuck at.
    back_out: bool,
    /// The plan under way is a back-out.
    backing_out: bool,
    /// The plan whose end has been acted on.
    ended: u64,
    /// The second look has been taken (see [`Exploration::second_look`]).
    second_look_taken: bool,
    /// Escapes from one stuck place in a row (see [`ESCAPE_ROUND`]).
    escape_attempts: u32,
    /// Where the last retrace began, and whether it was driven backward.
    retraced_from: Option<([f64; 3], bool)>,
    /// How the last plan ended ([`StopReason`] code, 0: at its end).
    last_stop: Option<StopReason>,
    /// Retraces refused in a row where the last one began.
    refused_here: u32,
    /// Plans in a row stopped for tilt where the one before was (see
    /// [`Exploration::count_tilt_stall`]), and where that was.
    tilt_stalls: u32,
    last_tilt_stop: [f64; 3],
    /// base_link over the ground, m: the track is base_link's, plans are
    /// on the ground ([`Exploration::set_base_height`]).
    base_height_m: f64,
    /// The energy drawn, from the drives' feedback, and the last feedback
    /// read.
    pub energy: EnergyMeter,
    drives_seen: u64,
}

/// Escapes from a stuck place, in turn: a back-out backward, one forward,
/// a retrace along the track forward, one backward.
const ESCAPE_ROUND: u32 = 4;
/// Retraces refused in a row at one place (each way twice) after which
/// the rover stops retracing there.
const RETRACE_REFUSALS_HERE: u32 = 4;
/// Tilt stops in a row without moving after which the rover is stranded.
const TILT_STALLS_TO_STRAND: u32 = 6;
/// Tilt stops this near each other count as one place, m.
const TILT_STALL_RADIUS_M: f64 = 0.1;

impl Exploration {
    /// All storage taken now (the coverage map around the origin).
    pub fn new(
        e: ExplorerParams,
        c: CandidateParams,
        target: Option<[f64; 2]>,
        settle_s: f64,
    ) -> Self {
        Exploration {
            energy: EnergyMeter::new(e.power),
            drives_seen: 0,
            explorer: Explorer::new(e, [0.0; 3]),
            scan: CandidateScan::new(c),
            target,
            settle_ns: (settle_s * 1e9) as u64,
            homed: false,
            executing: 0,
            idle_since: None,
            last_observed: [f64::INFINITY; 2],
            counters: ExplorationCounters::default(),
            sim: None,
            worker: None,
            dump: None,
            mount: Pose::identity(),
            validation_began_ns: 0,
            comparison: Comparison {
                query: 0,
                predicted: Vec::with_capacity(PREDICTION_POINTS),
                executed: Vec::with_capacity(PREDICTION_POINTS),
                moving_since: None,
                next_sample_ns: 0,
                active: false,
            },
            partial: Partial {
                poses: heapless::Vec::new(),
                predicted: Vec::with_capacity(PREDICTION_POINTS),
                length_m: 0.0,
                goal: [0.0; 3],
            },
            partial_scratch: Vec::with_capacity(PLAN_POSES),
            validation_ms: Vec::with_capacity(HISTORY),
            prediction_rmse_m: Vec::with_capacity(HISTORY),
            stranded: false,
            climbed_m: 0.0,
            descended_m: 0.0,
            no_go: heapless::Deque::new(),
            slides: heapless::Deque::new(),
            rims: heapless::Deque::new(),
            back_out: false,
            backing_out: false,
            ended: 0,
            second_look_taken: false,
            escape_attempts: 0,
            retraced_from: None,
            last_stop: None,
            refused_here: 0,
            tilt_stalls: 0,
            last_tilt_stop: [f64::INFINITY; 3],
            base_height_m: 0.0,
        }
    }

    /// A plan ended with `stop`: past the safety monitor's hard tilt limit
    /// no wheel turns, so plan after plan stops where it began (in the
    /// garage a rover hanging off a ramp's side at 42 degrees retraced,
    /// backward and forward, for the rest of the mission). After a few
    /// such stops in one place the rover is stranded and the mission ends.
    fn count_tilt_stall(&mut self, stop: Option<StopReason>, bus: &Bus) {
        let Some(p) = bus.slam.get().map(|p| p.value.position) else {
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
    fn note_rim(&mut self, bus: &Bus) {
        let rim = bus.command.get().and_then(|c| c.value.rim);
        let (Some([x, y]), Some(p)) = (rim, bus.slam.get().map(|p| p.value.position)) else {
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
    fn note_slide(&mut self, stop: Option<StopReason>, bus: &Bus) {
        let slid = [
            StopReason::OffPath,
            StopReason::NoProgress,
            StopReason::Stuck,
        ]
        .iter()
        .any(|r| Some(*r) == stop);
        if !slid || self.explorer.mode() != Mode::Exploring {
            return;
        }
        let Some(s) = bus.slam.get().map(|p| p.value) else {
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
        self.stranded |= matches!(self.explorer.mode(), Mode::Returning(_));
    }

    /// A query found no ground to start from under the rover, or nothing
    /// to explore from where it stands (the graph may be hemmed in: a way
    /// the rover came that the map has since come to refuse).
    pub fn no_start(&mut self) {
        self.stranded = true;
    }

    pub fn retrace_due(&self) -> bool {
        self.stranded && !matches!(self.explorer.mode(), Mode::Finished(_) | Mode::Stranded)
    }

    /// Drive back along the rover's own track, `ahead_m` of it, as plan
    /// `query`: the rover came this way, so it can go back. The map may
    /// have come to refuse the way (a low rim seen from the far side, a
    /// gap the planner no longer bridges); the safety monitor still
    /// watches every metre of it. With the internal simulator the
    /// retrace is only shown, and true returned: it is driven once the
    /// simulation passes it ([`Exploration::driving`]). So is a back-out
    /// ([`Exploration::back_out_passed`]), judged more leniently.
    pub fn retrace(&mut self, bus: &mut Bus, now: u64, query: u64, ahead_m: f64) -> bool {
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
                return self.back_out(bus, now, query, round == 1);
            }
        }
        self.backing_out = false;
        self.counters.retraces += 1;
        let Some((pose, yaw)) = bus.slam.get().map(|p| {
            let yaw = crate::tasks::control::yaw_of(p.value.orientation);
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
        let from = if matches!(self.explorer.mode(), Mode::Returning(_)) {
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
            let z = ground_at(bus, a[0], a[1], a[2] - self.base_height_m);
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
        bus.exploration.goal = Some(points[n - 1]);
        bus.plan.publish(now, msg);
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
    fn back_out(&mut self, bus: &mut Bus, now: u64, query: u64, forward: bool) -> bool {
        let Some(p) = bus.slam.get().map(|p| p.value) else {
            return false;
        };
        self.counters.backed_out += 1;
        self.backing_out = true;
        let yaw = crate::tasks::control::yaw_of(p.orientation);
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
            let z = ground_at(bus, x, y, ground);
            let _ = msg.poses.push([x as f32, y as f32, z as f32, yaw as f32]);
        }
        if !validate {
            self.back_out_passed(query);
        }
        // No goal: a back-out stopped on its way rejects no candidate.
        bus.exploration.goal = None;
        bus.plan.publish(now, msg);
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

    /// base_link's height over the ground, m (the planner's).
    pub fn set_base_height(&mut self, base_height_m: f64) {
        self.base_height_m = base_height_m;
    }

    /// Validate every plan in `sim` first, its world made of the keyframe
    /// clouds seen through `mount`.
    pub fn with_simulator(mut self, sim: InternalSim, mount: Pose) -> Self {
        self.sim = Some(Box::new(sim));
        self.mount = mount;
        self
    }

    /// Do the simulator's work on `worker` (but for the clouds' integration).
    pub fn with_worker(mut self, worker: SimWorker) -> Self {
        self.worker = Some(worker);
        self
    }

    /// Write every validation's inputs with `dump`.
    pub fn with_dump(mut self, dump: ValidationDump) -> Self {
        self.dump = Some(dump);
        self
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

    /// A query is over. If it drove nothing while a back-out waits (the
    /// planner was asked first after a stuck back-out), the back-out is
    /// next.
    pub fn query_over(&mut self) {
        if self.back_out {
            self.stranded = true;
        }
    }

    /// The planner's plan `query` is driven: no back-out is due any more.
    pub fn driving(&mut self, query: u64) {
        self.executing = query;
        self.counters.plans_executed += 1;
        self.explorer.driven();
        self.refused_here = 0;
        self.back_out = false;
        self.backing_out = false;
    }

    /// Whether plans are validated in the internal simulator first.
    pub fn validates(&self) -> bool {
        self.sim.is_some() || self.worker.as_ref().is_some_and(SimWorker::is_lent)
    }

    /// The simulator, taken back from the worker if a batch is out
    /// (waiting for it to end).
    pub fn sim_home(&mut self) -> Option<&mut InternalSim> {
        if let Some(sim) = self.worker.as_mut().and_then(SimWorker::join) {
            self.sim = Some(sim);
        }
        self.sim.as_deref_mut()
    }

    /// Lend the simulator to the worker for a batch, if there is one and
    /// the next step does not read the clouds.
    pub fn sim_lend(&mut self) {
        let Some(w) = self.worker.as_mut() else {
            return;
        };
        let Some(sim) = self.sim.take() else {
            return;
        };
        if let Err(sim) = w.lend(sim) {
            self.sim = Some(sim);
        }
    }

    /// The simulator's verdict on the plan under validation, at `now`.
    pub fn record_verdict(&mut self, outcome: Outcome, now: u64) {
        self.counters.validations += 1;
        if self.validation_ms.len() < HISTORY {
            let ms = now.saturating_sub(self.validation_began_ns) / 1_000_000;
            self.validation_ms.push(ms.min(u32::MAX as u64) as u32);
        }
        if let Some(sim) = &self.sim {
            self.counters.sim_physics_steps = sim.counters.physics_steps;
            self.counters.sim_triangles_max = sim.counters.triangles_max;
        }
        let k = match outcome {
            Outcome::Reached => {
                self.counters.validated += 1;
                return;
            }
            Outcome::Timeout => 0,
            Outcome::TippedOver => 1,
            Outcome::Stuck => 2,
            Outcome::Missed => 3,
            Outcome::NoGround => 4,
            Outcome::NoWayBack => 5,
            Outcome::Overhang => 6,
            Outcome::Fell => 7,
        };
        self.counters.rejected_by_sim += 1;
        self.counters.sim_outcomes[k] += 1;
    }

    /// Plan `query`, validated, is handed over: its real track will be
    /// compared with the prediction.
    pub fn compare_next(&mut self, query: u64) {
        let Some(sim) = &self.sim else { return };
        let c = &mut self.comparison;
        c.predicted.clear();
        c.predicted.extend_from_slice(sim.prediction());
        c.begin(query);
    }

    /// The simulation refused `plan` (to `goal`): keep its well-driven
    /// first part if it is the longest this query.
    pub fn offer_partial(&mut self, plan: &[[f32; 4]], goal: [f64; 3]) {
        let Some(sim) = self.sim.as_deref() else {
            return;
        };
        self.partial_scratch.clear();
        self.partial_scratch
            .extend(plan.iter().map(|p| p.map(f64::from)));
        let prediction = sim.prediction();
        if let Some(prefix) =
            driven_prefix(&self.partial_scratch, prediction, PrefixRule::default())
        {
            self.partial.offer(plan, prediction, prefix, goal);
        }
    }

    /// The partial plan is handed over as plan `query`: compared with the
    /// prediction up to its end.
    pub fn compare_partial(&mut self, query: u64) {
        let c = &mut self.comparison;
        c.predicted.clear();
        c.predicted.extend_from_slice(&self.partial.predicted);
        c.begin(query);
    }

    /// Sample the real track of the plan being compared; at its end, the
    /// RMSE against the prediction.
    fn follow_comparison(&mut self, bus: &Bus, now: u64) {
        let c = &mut self.comparison;
        if !c.active {
            return;
        }
        let (Some(cmd), Some(pose)) = (bus.command.get(), bus.slam.get()) else {
            return;
        };
        let cmd = cmd.value;
        if cmd.plan != c.query {
            return;
        }
        if c.moving_since.is_none() && (cmd.speed.abs() > 1e-3 || cmd.yaw_rate.abs() > 1e-3) {
            c.moving_since = Some(now);
            c.next_sample_ns = now;
        }
        if c.moving_since.is_some() && now >= c.next_sample_ns {
            if c.executed.len() < PREDICTION_POINTS {
                c.executed.push(pose.value.position);
            }
            c.next_sample_ns += 100_000_000;
        }
        if cmd.done {
            c.active = false;
            if let Some(e) = rmse_at_equal_times(&c.predicted, &c.executed) {
                tracing::debug!(
                    rmse_m = e,
                    predicted_s = c.predicted.len() as f64 * 0.1,
                    executed_s = c.executed.len() as f64 * 0.1,
                    "prediction compared"
                );
                if self.prediction_rmse_m.len() < HISTORY {
                    self.prediction_rmse_m.push(e);
                }
            }
        }
    }

    pub fn mode(&self) -> Mode {
        self.explorer.mode()
    }

    /// Every frame: follow the rover's pose; publish the state.
    pub fn observe(&mut self, bus: &mut Bus, now: u64) {
        self.follow_comparison(bus, now);
        self.meter_energy(bus, now);
        if let Some(p) = bus.slam.get().map(|p| p.value.position) {
            if !self.homed {
                self.explorer.restart(p);
                self.homed = true;
            }
            // Coverage and track change only as the rover moves.
            let moved = (p[0] - self.last_observed[0]).hypot(p[1] - self.last_observed[1]);
            let dz = p[2] - self.explorer.home()[2];
            self.climbed_m = self.climbed_m.max(dz);
            self.descended_m = self.descended_m.max(-dz);
            if moved >= 0.1 || now % 1_000_000_000 < 1_000_000 {
                self.explorer.observe(now as f64 * 1e-9, p);
                self.last_observed = [p[0], p[1]];
            }
        }
        bus.exploration = ExplorationStatus {
            phase: match self.explorer.mode() {
                Mode::Exploring => ExplorationPhase::Exploring,
                Mode::Returning(_) => ExplorationPhase::Returning,
                Mode::Finished(_) => ExplorationPhase::Finished,
                Mode::Stranded => ExplorationPhase::Stranded,
            },
            goal: bus.exploration.goal,
        };
    }

    /// Count the draw since the last frame from the drives' latest
    /// velocities and torques.
    fn meter_energy(&mut self, bus: &Bus, now: u64) {
        match bus.drives.newer_than(self.drives_seen) {
            Some(d) => {
                self.drives_seen = d.seq;
                let speed = d.value.nodes.map(|n| n.velocity as f64 * 1e-3);
                let torque = d.value.nodes.map(|n| n.torque.map(cia402::torque_nm));
                self.energy.read(now, &speed, &torque);
            }
            None => self.energy.advance(now),
        }
        self.explorer.set_energy_used(self.energy.used_wh());
    }

    /// Whether a query may begin: home is known, the mission is not over,
    /// the control task has finished the last plan (or has none) and the
    /// maps have had `settle_s` since.
    pub fn ready(&mut self, bus: &Bus, now: u64) -> bool {
        if !self.homed || matches!(self.explorer.mode(), Mode::Finished(_) | Mode::Stranded) {
            return false;
        }
        let idle = self.executing == 0
            || bus
                .command
                .get()
                .is_some_and(|c| c.value.plan == self.executing && c.value.done);
        if !idle {
            self.idle_since = None;
            return false;
        }
        if self.idle_since.is_none() && (self.executing == 0 || self.ended != self.executing) {
            // The traverse is over (seen once per plan: queries that drive
            // nothing leave the last plan's end standing): a goal the rover
            // was stopped on the way to is not tried again.
            self.ended = self.executing;
            let stop = bus.command.get().and_then(|c| c.value.stop);
            self.last_stop = stop;
            if let (true, Mode::Exploring, Some(g)) =
                (stop.is_some(), self.explorer.mode(), bus.exploration.goal)
            {
                self.explorer.reject([g[0], g[1]]);
            }
            // Stuck (on a rock the map took for ground, most often): the
            // place becomes an obstacle, and the rover backs out first.
            if stop == Some(StopReason::Stuck) {
                if let Some(p) = bus.slam.get().map(|p| p.value.position) {
                    let known = self
                        .no_go
                        .iter()
                        .any(|q| (q[0] - p[0]).hypot(q[1] - p[1]) < NO_GO_RADIUS_M / 2.0);
                    if !known {
                        if self.no_go.is_full() {
                            self.no_go.pop_front();
                        }
                        let _ = self.no_go.push_back(p);
                    }
                    // A back-out stuck too: the planner first, from
                    // where the rover now stands and with the place
                    // barred (the way out may need a turn no straight
                    // back-out makes); the next back-out, the other way,
                    // only when it finds nothing. Back-outs in a row
                    // pivoted a wedged rover a little each time and
                    // could go on for the rest of the mission.
                    self.back_out = true;
                    self.stranded = !self.backing_out;
                }
            } else if stop.is_none() {
                self.escape_attempts = 0;
            }
            self.note_slide(stop, bus);
            self.note_rim(bus);
            self.count_tilt_stall(stop, bus);
        }
        let since = *self.idle_since.get_or_insert(now);
        if now < since + self.settle_ns {
            return false;
        }
        self.idle_since = None;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use speleo_exploration::ReturnReason;
    use speleo_messages::SlamPose;

    fn at(bus: &mut Bus, p: [f64; 3]) {
        bus.slam.publish(
            0,
            SlamPose {
                position: p,
                orientation: [1.0, 0.0, 0.0, 0.0],
                keyframes: 1,
            },
        );
    }

    fn exploration() -> Exploration {
        Exploration::new(
            ExplorerParams::default(),
            CandidateParams::default(),
            None,
            1.0,
        )
    }

    #[test]
    fn the_drives_feedback_is_metered_and_the_budget_turns_the_rover_home() {
        use speleo_hal::canopen::supervisor::DrivesState;
        // Driving along x at 0.4 m/s, every wheel at 2 rad/s under 3 N m
        // (torque actual 200 of 1000): 45 W + 4 x (6 W / 0.7 + 0.54 W).
        let run = |torque: Option<i16>, budget_wh: f64| {
            let mut e = Exploration::new(
                ExplorerParams {
                    energy_budget_wh: budget_wh,
                    ..ExplorerParams::default()
                },
                CandidateParams::default(),
                None,
                1.0,
            );
            let mut bus = Bus::new();
            let mut drives = DrivesState::default();
            for n in drives.nodes.iter_mut() {
                n.velocity = 2000;
                n.torque = torque;
            }
            let mut turned_at = None;
            for k in 0..=10_000u64 {
                let now = k * 10_000_000;
                bus.drives.publish(now, drives);
                at(&mut bus, [k as f64 * 0.004, 0.0, 0.0]);
                e.observe(&mut bus, now);
                if turned_at.is_none() && e.mode() == Mode::Returning(ReturnReason::Energy) {
                    turned_at = Some(now as f64 * 1e-9);
                }
            }
            (e.energy.used_wh(), e.energy.unmeasured_s(), turned_at)
        };
        let watts = 45.0 + 4.0 * (6.0 / 0.7 + 0.06 * 9.0);
        let (wh, unmeasured, turned) = run(Some(200), 0.0);
        assert!((wh - watts * 100.0 / 3600.0).abs() < 1e-3, "{wh} Wh");
        assert_eq!((unmeasured, turned), (0.0, None));
        // A 5 Wh budget: home is as far as the rover has come, so it turns
        // at 2 Wh (2 + 1.5 x 2 = 5), 88 s out.
        let (_, _, turned) = run(Some(200), 5.0);
        let t = turned.unwrap_or_else(|| panic!("never turned home"));
        let expected = 2.0 * 3600.0 / watts;
        assert!(
            (t - expected).abs() < 1.0,
            "turned at {t} s, not {expected}"
        );
        // Drives that map no torque: the base alone, and the time counted.
        let (wh, unmeasured, _) = run(None, 0.0);
        assert!((wh - 45.0 * 100.0 / 3600.0).abs() < 1e-3, "{wh} Wh");
        assert!((unmeasured - 100.0).abs() < 0.02, "{unmeasured} s");
    }

    #[test]
    fn a_retrace_goes_back_the_way_the_rover_came_and_on_the_way_home_toward_home() {
        let mut e = exploration();
        let mut bus = Bus::new();
        // Out to 20 m, and back to 10 m.
        for k in 0..=20 {
            e.explorer.observe(k as f64, [k as f64, 0.0, 0.0]);
        }
        for k in (10..20).rev() {
            e.explorer.observe(40.0 - k as f64, [k as f64, 0.2, 0.0]);
        }
        at(&mut bus, [10.0, 0.1, 0.0]);
        let end = |bus: &Bus| bus.plan.get().and_then(|p| p.value.poses.last().copied());
        // Exploring: back where it just came from.
        e.retrace(&mut bus, 1, 1, 5.0);
        let out = end(&bus).unwrap_or_else(|| panic!("no retrace"));
        assert!(out[0] > 14.0, "{out:?}");
        // Going home: along the track from its first pass, toward home.
        for _ in 0..3 {
            e.explorer.query_result(false);
        }
        assert!(matches!(e.mode(), Mode::Returning(_)));
        e.retrace(&mut bus, 2, 2, 5.0);
        let home = end(&bus).unwrap_or_else(|| panic!("no retrace"));
        assert!(home[0] < 6.0, "{home:?}");
    }

    #[test]
    fn a_rover_stopped_at_the_maps_edge_retraces_without_turning_round() {
        use speleo_messages::WheelCommand;
        let heading_after_at = |stop: StopReason, yaw: f64, at: [f64; 3]| {
            let mut e = exploration();
            let mut bus = Bus::new();
            // Out along x to 10 m.
            for k in 0..=10 {
                e.explorer.observe(k as f64, [k as f64, 0.0, 0.0]);
            }
            e.homed = true;
            bus.slam.publish(
                0,
                SlamPose {
                    position: at,
                    orientation: [(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()],
                    keyframes: 1,
                },
            );
            bus.command.publish(
                0,
                WheelCommand {
                    done: true,
                    stop: Some(stop),
                    ..Default::default()
                },
            );
            assert!(!e.ready(&bus, 0), "settling");
            e.retrace(&mut bus, 1, 1, 4.0);
            let poses = bus.plan.get().map(|p| p.value.poses.clone());
            let poses = poses.unwrap_or_else(|| panic!("no retrace"));
            assert!(poses.iter().all(|q| q[0] <= 10.0 + 1e-3), "{poses:?}");
            poses[1][3]
        };
        let heading_after =
            |stop: StopReason, yaw: f64| heading_after_at(stop, yaw, [10.0, 0.0, 0.0]);
        // Blocked: back along the track, facing it (turning round first).
        assert!(heading_after(StopReason::Blocked, 0.0).abs() > 3.0);
        // At the map's edge: backing along it, facing the way it came.
        assert!(heading_after(StopReason::LeavingMap, 0.0).abs() < 0.1);
        // Stopped there backing up (facing back along the track): driven
        // forward, facing the way it faces still.
        let back = heading_after(StopReason::LeavingMap, std::f64::consts::PI);
        assert!(back.abs() > 3.0, "{back}");
        // The pose jumped 0.7 m sideways (a loop closure) after the stop:
        // the leg to the track's end point runs 60° right of the yaw, but
        // the track runs back the other way: backing along it still.
        let jumped = heading_after_at(StopReason::LeavingMap, 0.0, [9.6, 0.7, 0.0]);
        assert!(jumped.abs() < 0.1, "{jumped}");
    }

    #[test]
    fn a_retrace_does_not_drive_back_up_to_a_point_the_rover_slid_back_from() {
        let mut e = exploration();
        let mut bus = Bus::new();
        // Up a slope along x to 6 m, then slid back to 5.2 m: the track's
        // last point near the rover is 0.8 m ahead of it.
        for k in 0..=6 {
            e.explorer.observe(k as f64, [k as f64, 0.0, 0.0]);
        }
        at(&mut bus, [5.2, 0.0, 0.0]);
        e.retrace(&mut bus, 1, 1, 4.0);
        let poses = bus.plan.get().map(|p| p.value.poses.clone());
        let poses = poses.unwrap_or_else(|| panic!("no retrace"));
        assert!(poses.len() >= 3, "{poses:?}");
        // From where it stands straight back down, never up to x = 6.
        assert!(poses.iter().all(|q| q[0] <= 5.2 + 1e-3), "{poses:?}");
        assert!(poses[1][0] > 4.5 && poses[1][0] < 5.2, "{poses:?}");
    }

    #[test]
    fn tilt_stops_in_one_place_strand_the_rover_and_moving_on_resets_the_count() {
        let mut e = exploration();
        let mut bus = Bus::new();
        let tilt = Some(StopReason::Tilt);
        // Tilt stops that each got somewhere, or other stops between
        // them, never strand it.
        for k in 0..2 * TILT_STALLS_TO_STRAND {
            at(&mut bus, [k as f64, 0.0, 0.0]);
            e.count_tilt_stall(tilt, &bus);
        }
        at(&mut bus, [50.0, 0.0, 0.0]);
        for _ in 0..TILT_STALLS_TO_STRAND - 1 {
            e.count_tilt_stall(tilt, &bus);
        }
        e.count_tilt_stall(None, &bus);
        e.count_tilt_stall(tilt, &bus);
        assert_eq!(e.explorer.mode(), Mode::Exploring);
        // Stop after stop where it stood: stranded, the mission over.
        for _ in 0..TILT_STALLS_TO_STRAND {
            at(&mut bus, [50.02, 0.01, 0.0]);
            e.count_tilt_stall(tilt, &bus);
        }
        assert_eq!(e.explorer.mode(), Mode::Stranded);
        assert!(!e.retrace_due());
    }

    #[test]
    fn a_stop_pitched_up_a_steep_slope_is_kept_as_a_slide_once() {
        let mut e = exploration();
        e.set_base_height(0.15);
        let mut bus = Bus::new();
        let pitched = |bus: &mut Bus, p: [f64; 3], deg: f64| {
            let h = deg.to_radians() / 2.0;
            bus.slam.publish(
                0,
                SlamPose {
                    position: p,
                    orientation: [h.cos(), 0.0, h.sin(), 0.0],
                    keyframes: 1,
                },
            );
        };
        let off_path = Some(StopReason::OffPath);
        // Off the path on a garage ramp (14 deg), or tilted past the
        // limit: no slide.
        pitched(&mut bus, [1.0, 0.0, 0.5], -14.0);
        e.note_slide(off_path, &bus);
        pitched(&mut bus, [1.0, 0.0, 0.5], -21.0);
        e.note_slide(Some(StopReason::Tilt), &bus);
        assert!(e.slides.is_empty());
        // Slid off the path nose up at 21 deg: kept, on the ground.
        pitched(&mut bus, [-6.0, -1.0, 1.65], -21.0);
        e.note_slide(off_path, &bus);
        assert_eq!(e.slides.len(), 1);
        let s = *e.slides.front().expect("a slide");
        assert!((s[2] - 1.5).abs() < 1e-9, "{s:?}");
        // Stalled again beside it: the same place.
        pitched(&mut bus, [-6.2, -0.9, 1.7], 20.0);
        e.note_slide(Some(StopReason::NoProgress), &bus);
        assert_eq!((e.slides.len(), e.counters.slides), (1, 1));
        // Going home, a slide bars nothing (home may be up a slope).
        for _ in 0..3 {
            e.explorer.query_result(false);
        }
        assert!(matches!(e.mode(), Mode::Returning(_)));
        pitched(&mut bus, [30.0, 0.0, -3.0], -22.0);
        e.note_slide(Some(StopReason::Stuck), &bus);
        assert_eq!(e.slides.len(), 1);
    }

    #[test]
    fn a_stop_at_a_rim_is_kept_once_on_the_rovers_ground() {
        use speleo_messages::WheelCommand;
        let mut e = exploration();
        e.set_base_height(0.2);
        let mut bus = Bus::new();
        at(&mut bus, [3.0, 1.0, 9.2]);
        let stop = |bus: &mut Bus, rim: Option<[f64; 2]>| {
            bus.command.publish(
                0,
                WheelCommand {
                    done: true,
                    stop: Some(StopReason::LeavingMap),
                    rim,
                    ..Default::default()
                },
            );
        };
        // Ground unseen ahead: no rim.
        stop(&mut bus, None);
        e.note_rim(&bus);
        assert!(e.rims.is_empty());
        stop(&mut bus, Some([3.6, 1.9]));
        e.note_rim(&bus);
        stop(&mut bus, Some([3.7, 1.95]));
        e.note_rim(&bus);
        assert_eq!((e.rims.len(), e.counters.rims), (1, 1));
        let r = *e.rims.front().expect("a rim");
        assert!(
            (r[0] - 3.6).abs() < 1e-9 && (r[2] - 9.0).abs() < 1e-9,
            "{r:?}"
        );
        // Past the limit, the oldest goes.
        for k in 0..MAX_RIMS {
            stop(&mut bus, Some([10.0 + k as f64, 0.0]));
            e.note_rim(&bus);
        }
        assert_eq!(e.rims.len(), MAX_RIMS);
        assert!(e.rims.front().is_some_and(|r| r[0] == 10.0));
    }
}
