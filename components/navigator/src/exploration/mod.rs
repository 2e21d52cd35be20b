//! The exploration behaviour around the navigator's queries: when a
//! traverse is over and the maps have settled, a query grows the graph,
//! scans it for candidates and plans to them in turn; the first plan found
//! (and passed by the internal simulation) is handed to the control task to
//! drive. When nothing is left, or time is up, the goals come from the
//! rover's track home instead; when no plan is found, the recovery
//! behaviour (`recovery`) drives the rover back along its track or out of
//! where it is stuck.

mod comparison;
mod counters;
mod partial;
pub(crate) mod recovery;

pub use counters::ExplorationCounters;
pub use partial::Partial;
pub use recovery::{
    MAX_NO_GO, MAX_RIMS, MAX_SLIDES, NO_GO_RADIUS_M, RIM_RADIUS_M, SLIDE_PITCH_DEG, SLIDE_RADIUS_M,
    SLIDE_RISE_M,
};

use comparison::Comparison;
use speleo_control::StopReason;
use speleo_exploration::{
    CandidateParams, CandidateScan, EnergyMeter, Explorer, ExplorerParams, ExplorerPhase,
};
use speleo_messages::{ExplorationPhase, ExplorationStatus, PLAN_POSES};
use speleo_simulator::{InternalSim, Outcome, PREDICTION_POINTS};

use crate::input::{NavInput, Outbox};
use crate::rehearsal::Rehearsal;

/// Results kept for the report's medians.
const HISTORY: usize = 8192;

pub struct Exploration {
    pub explorer: Explorer,
    pub scan: CandidateScan,
    pub target: Option<[f64; 2]>,
    settle_ns: u64,
    /// The first SLAM pose has become home.
    pub(crate) homed: bool,
    /// The query whose plan the control task was given (0: none yet).
    pub executing: u64,
    /// Since when the control task has been seen idle.
    idle_since: Option<u64>,
    last_observed: [f64; 2],
    pub counters: ExplorationCounters,
    /// The internal simulator, when plans are validated first (`None`
    /// while a batch is out on the host's worker).
    pub sim: Option<Box<InternalSim>>,
    /// The simulator is lent to the host's worker.
    lent: bool,
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
            lent: false,
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

    /// base_link's height over the ground, m (the planner's).
    pub fn set_base_height(&mut self, base_height_m: f64) {
        self.base_height_m = base_height_m;
    }

    /// Validate every plan in `sim` first, its world made of the keyframe
    /// clouds.
    pub fn with_simulator(mut self, sim: InternalSim) -> Self {
        self.sim = Some(Box::new(sim));
        self
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
        self.sim.is_some() || self.lent
    }

    /// The simulator, taken back from the worker if a batch is out
    /// (waiting for it to end).
    pub fn sim_home(&mut self, host: &mut dyn Rehearsal) -> Option<&mut InternalSim> {
        if let Some(sim) = host.join() {
            self.sim = Some(sim);
        }
        self.lent = false;
        self.sim.as_deref_mut()
    }

    /// Lend the simulator to the worker for a batch, if there is one and
    /// the next step does not read the clouds.
    pub fn sim_lend(&mut self, host: &mut dyn Rehearsal) {
        if !host.offloads() {
            return;
        }
        let Some(sim) = self.sim.take() else {
            return;
        };
        match host.lend(sim) {
            Ok(()) => self.lent = true,
            Err(sim) => self.sim = Some(sim),
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
            if sim.refused_when_pessimistic() {
                self.counters.refused_when_pessimistic += 1;
            }
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
            Outcome::TooSteepForGrip => 8,
        };
        self.counters.rejected_by_sim += 1;
        self.counters.sim_outcomes[k] += 1;
    }

    pub fn phase(&self) -> ExplorerPhase {
        self.explorer.phase()
    }

    /// Every frame: follow the rover's pose; publish the state.
    pub fn observe(&mut self, input: &NavInput, out: &mut Outbox) {
        let now = input.now_ns;
        self.follow_comparison(input);
        self.meter_energy(input);
        if let Some(p) = input.slam.map(|p| p.value.position) {
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
        out.status = ExplorationStatus {
            phase: match self.explorer.phase() {
                ExplorerPhase::Exploring => ExplorationPhase::Exploring,
                ExplorerPhase::Returning(_) => ExplorationPhase::Returning,
                ExplorerPhase::Finished(_) => ExplorationPhase::Finished,
                ExplorerPhase::Stranded => ExplorationPhase::Stranded,
            },
            goal: out.status.goal,
        };
    }

    /// Count the draw since the last frame from the drives' latest
    /// velocities and torques.
    fn meter_energy(&mut self, input: &NavInput) {
        let now = input.now_ns;
        match input.drives.filter(|d| d.seq > self.drives_seen) {
            Some(d) => {
                self.drives_seen = d.seq;
                self.energy.read(now, &d.value.speed, &d.value.torque_nm);
            }
            None => self.energy.advance(now),
        }
        self.explorer.set_energy_used(self.energy.used_wh());
    }

    /// Whether a query may begin: home is known, the mission is not over,
    /// the control task has finished the last plan (or has none) and the
    /// maps have had `settle_s` since.
    pub fn ready(&mut self, input: &NavInput, out: &Outbox) -> bool {
        let now = input.now_ns;
        if !self.homed
            || matches!(
                self.explorer.phase(),
                ExplorerPhase::Finished(_) | ExplorerPhase::Stranded
            )
        {
            return false;
        }
        let idle = self.executing == 0
            || input
                .command
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
            let stop = input.command.and_then(|c| c.value.stop);
            self.last_stop = stop;
            if let (true, ExplorerPhase::Exploring, Some(g)) =
                (stop.is_some(), self.explorer.phase(), out.status.goal)
            {
                self.explorer.reject([g[0], g[1]]);
            }
            // Stuck (on a rock the map took for ground, most often): the
            // place becomes an obstacle, and the rover backs out first.
            if stop == Some(StopReason::Stuck) {
                if let Some(p) = input.slam.map(|p| p.value.position) {
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
            self.note_slide(stop, input);
            self.note_rim(input);
            self.count_tilt_stall(stop, input);
        }
        let since = *self.idle_since.get_or_insert(now);
        if now < since + self.settle_ns {
            return false;
        }
        self.idle_since = None;
        true
    }
}
