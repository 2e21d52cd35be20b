//! One validation: build the world around the plan, settle the rover,
//! drive the plan, judge.

use speleo_control::safety::tilt_stop_deg;
use speleo_control::{AccelLimiter, PlanFollower, MAX_WAYPOINTS, REVERSE_SPEED_SCALE};
use speleo_physics::{Mesh, PhysicsParams, PhysicsRover};

use crate::prediction::Prediction;
use crate::ribbon;
use crate::terrain::Terrain;
use crate::{SimulatorParams, Stance};

/// The keyframe clouds the world is made of: the map the rover built.
pub trait CloudSource {
    fn keyframes(&self) -> usize;
    /// Keyframe `k`'s sensor position in the map frame, once it has a pose.
    fn origin(&self, k: usize) -> Option<[f64; 3]>;
    /// Up to `n` of keyframe `k`'s points (map frame) from point `from`
    /// into `out` (cleared first); false when there are none left.
    fn points(&self, k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool;
    /// The intensities of the returns [`points`](Self::points) gives for
    /// the same arguments, into `out` (cleared first); left empty where
    /// none were measured.
    fn intensities(&self, k: usize, from: usize, n: usize, out: &mut Vec<u8>) {
        let _ = (k, from, n);
        out.clear();
    }
}

/// No clouds: for the steps that do not read them.
struct NoClouds;

impl CloudSource for NoClouds {
    fn keyframes(&self) -> usize {
        0
    }
    fn origin(&self, _: usize) -> Option<[f64; 3]> {
        None
    }
    fn points(&self, _: usize, _: usize, _: usize, _: &mut Vec<[f64; 3]>) -> bool {
        false
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The goal reached within the tolerance and the time.
    Reached,
    /// The time allowed ran out.
    Timeout,
    TippedOver,
    /// Commanded to move without moving (a step too high, a wedge).
    Stuck,
    /// The follower ended away from the goal.
    Missed,
    /// There was no ground under the rover (the map is empty there).
    NoGround,
    /// The goal was reached, down a slope the rover could not drive back
    /// up (see [`InternalSim::check_way_back`]).
    NoWayBack,
    /// The goal was reached with a wheel over an edge: no ground under
    /// its hub within its radius and `overhang_depth_m`.
    Overhang,
    /// The ground under the rover's wheels sloped more than
    /// [`SimulatorParams::low_grip_max_tilt_deg`] where it reads as low
    /// grip.
    TooSteepForGrip,
    /// The rover fell: sank faster than a drive down a step allows
    /// (`speleo_physics::rover::FALL_SPEED_MPS`, about half a metre of
    /// free fall), off a ledge the map shows as a slope or not at all.
    Fell,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Verdict {
    pub outcome: Outcome,
    /// Simulated time driving, s, and the distance left to the goal, m.
    pub drive_s: f64,
    pub goal_error_m: f64,
}

impl Verdict {
    pub fn success(&self) -> bool {
        self.outcome == Outcome::Reached
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimCounters {
    pub runs: u64,
    pub physics_steps: u64,
    /// The physics steps' contact load summed (narrow-phase tests and
    /// contact points, see [`PhysicsRover::contact_load`]): what a batch
    /// of them cost besides their number.
    pub contact_load: u64,
    pub points_integrated: u64,
    pub triangles_max: u64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    Idle,
    /// Taking the last validation's world down, a slice of its ground's
    /// colliders at a time.
    Teardown,
    /// Clearing the TSDF for this validation's box.
    Clear,
    /// Integrating keyframe `k - 1` from point `from`, newest first,
    /// `used` keyframes integrated so far.
    Integrate {
        k: usize,
        from: usize,
        used: usize,
    },
    /// The rover put down, with the ground the scans miss: a pad under
    /// it and a strip along the plan.
    Base,
    /// Meshing tile `tile` into the world.
    Ground {
        tile: usize,
    },
    Drive,
    Done,
}

/// Which of a validation's two rollouts is under way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Leg {
    /// On the map as it reads, the rover put down as
    /// [`SimulatorParams::start_tilted`] says.
    Nominal,
    /// On the same ground at [`SimulatorParams::pessimistic_friction`],
    /// the rover started as it stands, with the tilt margin.
    Pessimistic,
}

/// Work units of ~25-30 us at the median, from
/// `benches/validation_phases.rs` on the short tube: 256 points integrated
/// (~28 us), a 0.25 m tile meshed and added to the world (~10 us and
/// ~0.85 us a triangle: median ~46 us, 0.5 ms for the 600 triangles of a
/// wall), a 10 ms physics step (~77 us, p99.9 ~185 us), 32 ground
/// colliders removed (~25 us), the TSDF cleared (~220 us).
const POINTS_PER_UNIT: usize = 256;
const UNITS_PER_STEP: usize = 6;
/// A physics step costs [`UNITS_PER_STEP`] up to this contact load (the
/// narrow phase's contact tests and the points found, see
/// [`PhysicsRover::contact_load`]), and a unit more for each
/// [`LOAD_PER_UNIT`] over it. Replayed, the default lava mission's 244,800
/// steps took 101 us at the median and 445 us at p99.9; the heaviest, a
/// rover lying on its chassis on rough ground with ~1,000 contact points,
/// took up to 0.95 ms, and at a flat 6 units 20 of them filled a frame's
/// batch to 15 ms. Charged by their load, no replayed batch passed 7.3 ms.
/// The threshold is high so that only those rare steps are charged more:
/// a verdict comes at another frame only in a validation that has them.
const LOAD_PER_STEP: usize = 1200;
const LOAD_PER_UNIT: usize = 40;

/// Units a physics step costs over [`UNITS_PER_STEP`] for the contact
/// load it left (pairs, tests, points).
fn overload_units([_, tests, points]: [usize; 3]) -> usize {
    (tests + points).saturating_sub(LOAD_PER_STEP) / LOAD_PER_UNIT
}
/// A tile costs a unit and one more for each of these triangles.
const TRIANGLES_PER_UNIT: usize = 32;
const COLLIDERS_PER_UNIT: usize = 32;
const UNITS_PER_CLEAR: usize = 8;
/// The base costs a unit and one more for each of these vertices laid
/// on the seen ground (a column searched each).
const VERTICES_PER_UNIT: usize = 24;
/// The ribbon's width beyond the wheels and length beyond the body, m:
/// the follower's straying from the path.
const RIBBON_MARGIN_M: f64 = 0.3;
/// Turning this much on the spot is progress, rad.
const STUCK_TURN_RAD: f64 = 0.3;
/// The rover is put down this far over its estimated ground, m.
const DROP_M: f64 = 0.08;
/// Keyframes whose sensor stood this far under the plan's lowest ground
/// are left out of its world, m: from a level below they see only the
/// underside of the floor the plan drives on. With SLAM's drift between
/// levels (the garage rover's height estimate sank on the way up a ramp),
/// that underside lay over the floor's top seen from above, and the rays
/// from below carved the floor away: the simulated rover tipped over or
/// stuck in the holes where the real one stood level. Not less: from a
/// ramp's foot the rings see the ramp's middle, over the sensor.
const BELOW_PLAN_M: f64 = 1.5;
/// Rays down through this far under the plan's lowest ground mark the
/// columns they cross as drops (see `Terrain::seen_through`), m: further
/// than the scans' noise and SLAM's drift put the floor's own points.
const THROUGH_UNDER_PLAN_M: f64 = 0.15;
/// Half the side of the ground pad under the rover at the start, m.
const FOOTPRINT_PAD_M: f64 = 1.0;
/// The follower runs at 50 Hz, as the control task does.
const CONTROL_PERIOD_S: f64 = 0.02;
const SAMPLE_PERIOD_S: f64 = 0.1;
/// The ground's grip under the rover is read this many voxels deeper
/// than where the wheels stand on it too (they sink into the mesh).
const GROUND_BELOW_VOXELS: i32 = 3;
/// The ground under a hub is looked for this far under the wheel, m.
const GROUND_PROBE_M: f64 = 0.3;
/// A rover standing within this of the tilt limit on low grip, deg, is
/// not held to it: the map's slope there moves by a few degrees as scans
/// come in, and the way the rover came must stay open (a rover stopped at
/// 21.5 degrees under a 22 degree limit had every way down refused).
const GRIP_EXEMPT_DEG: f64 = 3.0;

/// See the crate documentation.
pub struct InternalSim {
    p: SimulatorParams,
    terrain: Terrain,
    rover: Option<Box<PhysicsRover>>,
    follower: PlanFollower,
    limiter: AccelLimiter,
    plan: heapless::Vec<[f64; 4], MAX_WAYPOINTS>,
    /// base_link at the start.
    start: Stance,
    phase: Phase,
    step: u64,
    targets: [f64; 4],
    /// The follower's last command after the ramps (v m/s, w rad/s).
    command: (f64, f64),
    /// Ground given instead of the clouds' ([`InternalSim::begin_on`]).
    given_ground: Option<Mesh>,
    /// Steps since motion began, once it has.
    moving_since: Option<u64>,
    /// Whether the way back is driven once the goal is reached.
    way_back: bool,
    /// Driving the way back: the step it began and the verdict the plan
    /// itself got.
    returning: Option<(u64, Verdict)>,
    time_allowed_s: f64,
    /// The world's box, low and high corners.
    bounds: ([f64; 3], [f64; 3]),
    /// The lowest of the plan's ground and the start, m.
    lowest_z: f64,
    /// Stuck detection: when, where and at which heading progress was
    /// last seen (turning on the spot is progress too).
    anchor: (f64, [f64; 2], f64),
    /// Tilt past this is a tip-over, deg: `tip_over_deg`, or for a rover
    /// that starts beyond it, as the safety monitor allows such a start.
    tilt_limit_deg: f64,
    /// The run started past `tip_over_deg`.
    tilted_start: bool,
    prediction: Prediction,
    scratch: Vec<[f64; 3]>,
    scratch_intensities: Vec<u8>,
    verdict: Option<Verdict>,
    pub counters: SimCounters,
    leg: Leg,
    /// The plan and the start as given (the way back reverses the plan;
    /// the nominal rollout may put the rover down level).
    plan_given: heapless::Vec<[f64; 4], MAX_WAYPOINTS>,
    start_given: Stance,
    /// The nominal rollout's verdict, while the pessimistic one runs.
    nominal: Option<Verdict>,
    /// The rover's build on the pessimistic rollout's ground.
    pessimistic_physics: PhysicsParams,
    /// The teardown keeps the TSDF: the pessimistic rollout's world is
    /// meshed again from the same scans.
    keep_tsdf: bool,
    /// The nominal rollout's tilt after its first step, deg.
    start_tilt_deg: f64,
}

impl InternalSim {
    pub fn new(p: SimulatorParams) -> Result<Self, String> {
        p.check()?;
        Ok(InternalSim {
            terrain: Terrain::new(&p)?,
            rover: None,
            follower: PlanFollower::new(p.follower.clone()),
            limiter: AccelLimiter::new(p.limits),
            plan: heapless::Vec::new(),
            start: Stance::default(),
            phase: Phase::Idle,
            step: 0,
            targets: [0.0; 4],
            command: (0.0, 0.0),
            given_ground: None,
            moving_since: None,
            way_back: false,
            returning: None,
            time_allowed_s: 0.0,
            bounds: ([0.0; 3], [0.0; 3]),
            lowest_z: 0.0,
            anchor: (0.0, [0.0; 2], 0.0),
            tilt_limit_deg: p.tip_over_deg,
            tilted_start: false,
            prediction: Prediction::with_capacity(),
            scratch: Vec::with_capacity(POINTS_PER_UNIT * 64),
            scratch_intensities: Vec::with_capacity(POINTS_PER_UNIT * 64),
            verdict: None,
            counters: SimCounters::default(),
            leg: Leg::Nominal,
            plan_given: heapless::Vec::new(),
            start_given: Stance::default(),
            nominal: None,
            pessimistic_physics: p.physics.clone(),
            keep_tsdf: false,
            start_tilt_deg: 0.0,
            p,
        })
    }

    pub fn params(&self) -> &SimulatorParams {
        &self.p
    }

    /// Validate `plan` (x, y, ground z, heading) for the rover standing
    /// at `start`, all in the map frame.
    pub fn begin(&mut self, start: Stance, plan: impl IntoIterator<Item = [f64; 4]>) {
        self.plan.clear();
        for q in plan {
            if self.plan.push(q).is_err() {
                break;
            }
        }
        self.plan_given.clone_from(&self.plan);
        self.start_given = start;
        self.leg = Leg::Nominal;
        self.nominal = None;
        self.keep_tsdf = false;
        self.start_tilt_deg = 0.0;
        let tilt_deg = start.up()[2].clamp(-1.0, 1.0).acos().to_degrees();
        self.start = if self.p.start_tilted || tilt_deg > self.p.start_tilted_over_deg {
            start
        } else {
            let [x, y, z, yaw] = start.xyz_yaw();
            Stance::level(x, y, z, yaw)
        };
        let mut lo = start.position;
        let mut hi = lo;
        for q in &self.plan {
            for k in 0..3 {
                lo[k] = lo[k].min(q[k]);
                hi[k] = hi[k].max(q[k]);
            }
        }
        self.lowest_z = lo[2];
        let m = self.p.margin_m;
        // Drops a metre under the plan; walls and roof up to where the body
        // (0.7 m) could meet them.
        self.bounds = (
            [lo[0] - m, lo[1] - m, lo[2] - 1.0],
            [hi[0] + m, hi[1] + m, hi[2] + 1.5],
        );
        let length: f64 = self
            .plan
            .windows(2)
            .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
            .sum();
        self.time_allowed_s = self.p.time_factor * length / self.p.follower.cruise_speed.max(0.05)
            + self.p.time_extra_s;
        self.prediction.clear();
        self.verdict = None;
        self.moving_since = None;
        self.way_back = false;
        self.returning = None;
        self.step = 0;
        self.tilt_limit_deg = self.p.tip_over_deg;
        self.tilted_start = false;
        self.targets = [0.0; 4];
        self.command = (0.0, 0.0);
        self.limiter.halt();
        self.counters.runs += 1;
        self.given_ground = None;
        // The last world is taken down and the TSDF cleared in the steps.
        self.phase = Phase::Teardown;
    }

    /// Like [`InternalSim::begin`], but on `ground` as it is (no clouds,
    /// no pad or strip): to drive a plan on a world's true surface, away
    /// from the mission (`speleo validate --world`). Allocates.
    pub fn begin_on(
        &mut self,
        start: Stance,
        plan: impl IntoIterator<Item = [f64; 4]>,
        ground: Mesh,
    ) {
        self.begin(start, plan);
        self.given_ground = Some(ground);
    }

    /// Once the plan begun last has reached its goal down a slope (the
    /// rover's lowest point on the way more than
    /// [`SimulatorParams::way_back_drop_m`] under its start), drive it
    /// back, backward along the plan to the start, in the same world:
    /// the plan passes only if that reaches the start too, without
    /// tilting past [`SimulatorParams::tip_over_deg`] or sticking.
    /// Otherwise its verdict is [`Outcome::NoWayBack`]. The prediction
    /// and the verdict's time and goal error stay the plan's own. For
    /// exploring plans: in the lava tube a rover that drove down along a
    /// wall's foot at the far end found no way back up (every one tilted
    /// past the safety monitor's 30 degrees, on the map and on the true
    /// surface alike) and was stranded there.
    pub fn check_way_back(&mut self) {
        self.way_back = self.p.way_back_drop_m > 0.0;
    }

    /// What the next step works on: "integrate", "ground", "drive", or
    /// "idle" (no validation, or its verdict is in).
    pub fn work(&self) -> &'static str {
        match self.phase {
            Phase::Teardown | Phase::Clear => "clear",
            Phase::Integrate { .. } => "integrate",
            Phase::Base => "base",
            Phase::Ground { .. } => "ground",
            Phase::Drive => "drive",
            Phase::Idle | Phase::Done => "idle",
        }
    }

    /// The trajectory predicted so far: positions every 0.1 s since motion began.
    pub fn prediction(&self) -> &[[f64; 3]] {
        &self.prediction.points
    }

    pub fn verdict(&self) -> Option<Verdict> {
        self.verdict
    }

    /// Triangles of the world built.
    pub fn triangles(&self) -> usize {
        self.terrain.triangles
    }

    /// The box whose points the validation under way integrates (from
    /// [`InternalSim::begin`]): the rest of the clouds is dropped unread.
    pub fn integrated_box(&self) -> ([f64; 3], [f64; 3]) {
        self.terrain.grown(self.bounds.0, self.bounds.1)
    }

    /// The points of the clouds the validation under way reads: those of
    /// [`integrated_box`](Self::integrated_box) and the rays down past
    /// the plan's level within it.
    pub fn read_region(&self) -> crate::ReadRegion {
        let (lo, hi) = self.integrated_box();
        crate::ReadRegion {
            lo,
            hi,
            through_z: self.through_z(),
        }
    }

    /// The plane rays down through mark drops at (see
    /// `Terrain::seen_through`).
    fn through_z(&self) -> f64 {
        self.lowest_z - THROUGH_UNDER_PLAN_M
    }

    /// The physics' contact load after the last step (see
    /// [`PhysicsRover::contact_load`]); zero before the rover is put down.
    pub fn contact_load(&self) -> [usize; 3] {
        self.rover.as_ref().map_or([0; 3], |r| r.contact_load())
    }

    /// The simulated rover's state after the last physics step, once it
    /// has been put down.
    pub fn rover_state(&self) -> Option<&speleo_physics::BodyState> {
        self.rover.as_deref().map(PhysicsRover::state)
    }

    /// The follower's last command, as the drives get it (v m/s, w rad/s).
    pub fn command(&self) -> (f64, f64) {
        self.command
    }

    /// The world built for this validation (the ground colliders'
    /// triangles, pad and strip included), once the rover is put down.
    pub fn world_mesh(&self) -> Option<Mesh> {
        self.rover.as_deref().map(PhysicsRover::ground_mesh)
    }

    pub fn memory_bytes(&self) -> usize {
        self.terrain.memory_bytes()
    }

    /// Up to `units` of work (at least one item of it, at most `units`
    /// but for a tile's triangles, which are known only once it is
    /// meshed); the verdict once there is one.
    pub fn step(&mut self, clouds: &impl CloudSource, units: usize) -> Option<Verdict> {
        self.advance(Some(clouds), units)
    }

    /// Whether the next step integrates the keyframe clouds (the one part
    /// of a validation that reads them).
    pub fn needs_clouds(&self) -> bool {
        matches!(self.phase, Phase::Integrate { .. })
    }

    /// Like [`InternalSim::step`] without the clouds (on a thread that
    /// cannot read them): stops short, its units unspent, where the
    /// clouds are integrated ([`InternalSim::needs_clouds`]).
    pub fn step_without_clouds(&mut self, units: usize) -> Option<Verdict> {
        self.advance(None::<&NoClouds>, units)
    }

    fn advance<C: CloudSource>(&mut self, clouds: Option<&C>, units: usize) -> Option<Verdict> {
        let mut left = units.max(1);
        let mut first = true;
        while left > 0 {
            if clouds.is_none() && self.needs_clouds() {
                return None;
            }
            let cost = match self.phase {
                Phase::Idle | Phase::Done => return self.verdict,
                Phase::Teardown | Phase::Integrate { .. } | Phase::Base | Phase::Ground { .. } => 1,
                Phase::Clear => UNITS_PER_CLEAR,
                Phase::Drive => UNITS_PER_STEP,
            };
            if cost > left && !first {
                break;
            }
            first = false;
            left -= cost.min(left);
            match self.phase {
                Phase::Idle | Phase::Done => {}
                Phase::Teardown => self.phase = self.teardown(),
                Phase::Clear => {
                    let through = self.through_z();
                    self.terrain.begin(self.bounds.0, self.bounds.1, through);
                    self.phase = if self.given_ground.is_some() {
                        Phase::Base
                    } else {
                        // From the newest keyframe there is when it begins.
                        Phase::Integrate {
                            k: usize::MAX,
                            from: 0,
                            used: 0,
                        }
                    };
                }
                Phase::Integrate { k, from, used } => {
                    if let Some(c) = clouds {
                        self.phase = self.integrate(c, k, from, used);
                    }
                }
                Phase::Base => {
                    let vertices = self.begin_ground();
                    left = left.saturating_sub(vertices / VERTICES_PER_UNIT);
                }
                Phase::Ground { tile } if tile < self.terrain.tiles && !self.near_plan(tile) => {
                    // Ground the rover cannot reach on this plan.
                    self.phase = Phase::Ground { tile: tile + 1 };
                }
                Phase::Ground { tile } => {
                    let before = self.terrain.triangles;
                    self.phase = self.ground(tile);
                    let extra = (self.terrain.triangles - before) / TRIANGLES_PER_UNIT;
                    left = left.saturating_sub(extra);
                }
                Phase::Drive => {
                    let verdict = self.drive();
                    let load = self.contact_load();
                    self.counters.contact_load += (load[1] + load[2]) as u64;
                    left = left.saturating_sub(overload_units(load));
                    if let Some(v) = verdict {
                        self.verdict = Some(v);
                        self.phase = Phase::Done;
                    }
                }
            }
        }
        self.verdict
    }

    /// A slice of the last world's colliders removed; the world dropped
    /// once its ground is gone.
    fn teardown(&mut self) -> Phase {
        if let Some(r) = &mut self.rover {
            if r.remove_ground(COLLIDERS_PER_UNIT) > 0 {
                return Phase::Teardown;
            }
        }
        self.rover = None;
        if core::mem::take(&mut self.keep_tsdf) {
            Phase::Base
        } else {
            Phase::Clear
        }
    }

    /// Keyframe `k - 1` integrated from point `from` (a unit's worth),
    /// when it is near the plan's box and not far under its ground; the
    /// newest `newest_keyframes` of those only.
    ///
    /// Why the newest: where the rover comes back, SLAM may not yet have
    /// closed the loop between its latest keyframes, which agree with its
    /// estimated pose, and those of its first pass. In the garage the two
    /// passes' floors lay 11 cm apart; integrated together they made a
    /// floor of two layers and fragments over it, and the simulated rover,
    /// turning round on the spot there, stuck on them at every retrace
    /// while the real one turned freely. The newest 20 made one floor.
    fn integrate(
        &mut self,
        clouds: &impl CloudSource,
        k: usize,
        from: usize,
        used: usize,
    ) -> Phase {
        let k = k.min(clouds.keyframes());
        if k == 0 || used >= self.p.newest_keyframes {
            return Phase::Base;
        }
        let next = Phase::Integrate {
            k: k - 1,
            from: 0,
            used,
        };
        let Some(origin) = clouds.origin(k - 1) else {
            return next;
        };
        if !self.terrain.near(origin, self.p.cloud_range_m)
            || origin[2] < self.lowest_z - BELOW_PLAN_M
        {
            return next;
        }
        let more = clouds.points(k - 1, from, POINTS_PER_UNIT, &mut self.scratch);
        clouds.intensities(k - 1, from, POINTS_PER_UNIT, &mut self.scratch_intensities);
        self.counters.points_integrated +=
            self.terrain
                .integrate(origin, &mut self.scratch, &mut self.scratch_intensities);
        if more {
            Phase::Integrate {
                k,
                from: from + POINTS_PER_UNIT,
                used,
            }
        } else {
            Phase::Integrate {
                k: k - 1,
                from: 0,
                used: used + 1,
            }
        }
    }

    /// Put the rover down with the ground the scans miss; the vertices
    /// laid on the seen ground (the cost of this step).
    fn begin_ground(&mut self) -> usize {
        let [x, y, z, yaw] = self.start.xyz_yaw();
        let tilt = [self.start.pitch, self.start.roll];
        let ph = match self.leg {
            Leg::Nominal => &self.p.physics,
            Leg::Pessimistic => &self.pessimistic_physics,
        };
        let dt = self.p.dt_s;
        // Dropped from a little higher than the estimate: legs started
        // inside a floor the TSDF puts a few centimetres higher than the
        // estimate would be thrown out of it.
        let ground = [x, y, z - self.p.base_height_m + DROP_M, yaw];
        if let Some(mesh) = &self.given_ground {
            let vertices = mesh.vertices.len();
            match PhysicsRover::new_tilted(ph, mesh, ground, tilt, dt) {
                Ok(r) => {
                    self.rover = Some(Box::new(r));
                    self.phase = Phase::Drive;
                }
                Err(_) => self.phase = self.finish(Outcome::NoGround),
            }
            return vertices;
        }
        // On the floor the map has round the rover, where it saw one: the
        // estimate may sit under it or over it (see `ribbon::floor_around`).
        // Both follow the plane the rover stands on, tilted as it is.
        let slope = self.start.ground_gradient();
        let estimate = z - self.p.base_height_m;
        let floor =
            ribbon::floor_around(&self.terrain, [x, y, estimate], slope).unwrap_or(estimate);
        let ground = [x, y, floor + DROP_M, yaw];
        match PhysicsRover::new_tilted(ph, &Mesh::default(), ground, tilt, dt) {
            Ok(mut r) => {
                // The LiDAR cannot see the ground under and around the
                // rover (its lowest beam meets the ground about a metre
                // away), but the rover stands there: a pad fills that
                // hole, and a strip along the plan the holes the rings
                // leave and the ground past a frontier goal.
                let footing = ribbon::Footing {
                    at: [x, y, ground[2] - DROP_M],
                    slope,
                    half: FOOTPRINT_PAD_M,
                };
                let mut pad = ribbon::pad(&self.terrain, &footing);
                // Level, the strip follows the plan as it always did.
                let tilted = slope != [0.0; 2];
                let mut strip = self.ribbon(tilted.then_some(&footing), footing.at);
                self.terrain.read_grip(&mut pad);
                self.terrain.read_grip(&mut strip);
                let _ = r.add_ground(&pad);
                let _ = r.add_ground(&strip);
                self.rover = Some(Box::new(r));
                self.phase = Phase::Ground { tile: 0 };
                pad.vertices.len() + strip.vertices.len() + ribbon::FLOOR_SAMPLES
            }
            Err(_) => {
                self.phase = self.finish(Outcome::NoGround);
                0
            }
        }
    }

    /// The strip of ground along the plan: the planner's belief where
    /// the scans have a hole. As wide as the wheels plus the follower's
    /// straying, and a body's half length past both ends of the plan
    /// (the rover's front is past a frontier goal's seen ground).
    fn ribbon(&self, footing: Option<&ribbon::Footing>, start_ground: [f64; 3]) -> Mesh {
        let ph = &self.p.physics;
        let half_w = 0.5 * ph.track_width_m + ph.wheel_radius_m + RIBBON_MARGIN_M;
        let beyond = 0.5 * ph.wheelbase_m + ph.wheel_radius_m + RIBBON_MARGIN_M;
        let mut path = Vec::with_capacity(self.plan.len() + 1);
        path.push(start_ground);
        path.extend(self.plan.iter().map(|q| [q[0], q[1], q[2]]));
        ribbon::strip(&self.terrain, &path, half_w, beyond, footing)
    }

    /// Whether tile `i` lies within the margin of the plan (or the start).
    fn near_plan(&self, i: usize) -> bool {
        let (lo, hi) = self.terrain.tile_bounds(i);
        let c = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        let reach = self.p.margin_m + 0.5 * (hi[0] - lo[0]).hypot(hi[1] - lo[1]);
        let start = [self.start.position[0], self.start.position[1]];
        let mut prev = start;
        let mut near = (c[0] - start[0]).hypot(c[1] - start[1]) <= reach;
        for q in &self.plan {
            let p = [q[0], q[1]];
            near |= segment_distance(c, prev, p) <= reach;
            prev = p;
        }
        near
    }

    fn ground(&mut self, tile: usize) -> Phase {
        if tile >= self.terrain.tiles {
            self.counters.triangles_max = self
                .counters
                .triangles_max
                .max(self.terrain.triangles as u64);
            if self.terrain.triangles == 0 {
                return self.finish(Outcome::NoGround);
            }
            return Phase::Drive;
        }
        self.terrain.mesh_tile(tile);
        if !self.terrain.chunk.triangles.is_empty() {
            if let Some(r) = &mut self.rover {
                // A degenerate tile is left out; the rest still holds.
                let _ = r.add_ground_smooth(&self.terrain.chunk);
            }
        }
        Phase::Ground { tile: tile + 1 }
    }

    fn finish(&mut self, outcome: Outcome) -> Phase {
        let verdict = if let Some(n) = self.nominal {
            // The pessimistic rollout's outcome, with the nominal one's
            // figures (its prediction is the one kept).
            Verdict { outcome, ..n }
        } else if let Some((_, plan)) = self.returning {
            if outcome == Outcome::Reached {
                plan
            } else {
                Verdict {
                    outcome: Outcome::NoWayBack,
                    ..plan
                }
            }
        } else {
            Verdict {
                outcome,
                drive_s: self
                    .moving_since
                    .map_or(0.0, |s| (self.step - s) as f64 * self.p.dt_s),
                goal_error_m: self.goal_error(),
            }
        };
        // A rover that starts as steep as the pessimistic tip limit
        // allows (within the safety monitor's growth of it) has no margin
        // left to keep and no safer choice than a way off the slope: the
        // nominal rollout judges it alone.
        let margin_left = self.p.tip_over_deg - self.p.pessimistic_tilt_margin_deg;
        let pessimistic = self.p.pessimistic_friction > 0.0
            && tilt_stop_deg(margin_left, self.start_tilt_deg) <= margin_left
            && self.climbed_m() > self.p.pessimistic_climb_m;
        if verdict.success() && self.leg == Leg::Nominal && pessimistic {
            self.verdict = None;
            self.nominal = Some(verdict);
            return self.begin_pessimistic();
        }
        self.verdict = Some(verdict);
        Phase::Done
    }

    /// The plan again, on the nominal world's scans re-meshed with the
    /// ground's friction at [`SimulatorParams::pessimistic_friction`], the
    /// rover started as it stands and judged against the tip limit less
    /// [`SimulatorParams::pessimistic_tilt_margin_deg`].
    fn begin_pessimistic(&mut self) -> Phase {
        self.leg = Leg::Pessimistic;
        self.pessimistic_physics = pessimistic_physics(&self.p, &self.start_given);
        self.plan.clone_from(&self.plan_given);
        self.start = self.start_given;
        self.way_back = false;
        self.returning = None;
        self.moving_since = None;
        self.step = 0;
        self.tilt_limit_deg = self.tip_limit_deg();
        self.tilted_start = false;
        self.targets = [0.0; 4];
        self.command = (0.0, 0.0);
        self.limiter.halt();
        self.keep_tsdf = true;
        Phase::Teardown
    }

    /// Tilt past this is a tip-over, deg: the pessimistic rollout keeps
    /// its margin.
    fn tip_limit_deg(&self) -> f64 {
        match self.leg {
            Leg::Nominal => self.p.tip_over_deg,
            Leg::Pessimistic => self.p.tip_over_deg - self.p.pessimistic_tilt_margin_deg,
        }
    }

    /// Whether the verdict in is a refusal by the pessimistic rollout
    /// after the nominal one passed.
    pub fn refused_when_pessimistic(&self) -> bool {
        self.leg == Leg::Pessimistic && self.verdict.is_some_and(|v| !v.success())
    }

    fn goal_error(&self) -> f64 {
        match (&self.rover, self.plan.last()) {
            (Some(r), Some(g)) => {
                let p = r.state().position;
                (p[0] - g[0]).hypot(p[1] - g[1])
            }
            _ => f64::INFINITY,
        }
    }

    /// One physics step; the follower every control period.
    fn drive(&mut self) -> Option<Verdict> {
        let tip = self.tip_limit_deg();
        let Some(rover) = &mut self.rover else {
            return Some(Verdict {
                outcome: Outcome::NoGround,
                drive_s: 0.0,
                goal_error_m: f64::INFINITY,
            });
        };
        let dt = self.p.dt_s;
        let t = self.step as f64 * dt;
        let control_every = (CONTROL_PERIOD_S / dt).round().max(1.0) as u64;
        let settle_steps = (self.p.settle_s / dt).round() as u64;
        let s = *rover.state();
        let [w, qx, qy, qz] = s.orientation;
        let yaw = (2.0 * (w * qz + qx * qy)).atan2(1.0 - 2.0 * (qy * qy + qz * qz));
        let tilt = (1.0 - 2.0 * (qx * qx + qy * qy))
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        let (x, y) = (s.position[0], s.position[1]);
        if self.step == settle_steps {
            let poses = self.plan.iter().map(|q| [q[0], q[1], q[3]]);
            if !self.follower.set_plan(poses) {
                self.moving_since = Some(self.step);
            }
            self.anchor = (t, [x, y], yaw);
        }
        if self.step >= settle_steps && self.step.is_multiple_of(control_every) {
            let c = self.follower.command(x, y, yaw);
            let (v, wz) = self.limiter.step(c.v, c.w, CONTROL_PERIOD_S);
            self.command = (v, wz);
            self.targets = self.p.skid.wheel_speeds(v, wz);
            if self.moving_since.is_none() && (v.abs() > 1e-3 || wz.abs() > 1e-3) {
                self.moving_since = Some(self.step);
            }
        }
        if let (Some(since), None, Leg::Nominal) = (self.moving_since, self.returning, self.leg) {
            let every = (SAMPLE_PERIOD_S / dt).round().max(1.0) as u64;
            if (self.step - since).is_multiple_of(every) {
                self.prediction.push(s.position);
            }
        }
        let t_ns = ((self.step + 1) as f64 * dt * 1e9) as u64;
        rover.step(t_ns, &self.targets);
        self.step += 1;
        self.counters.physics_steps += 1;
        // The judgement.
        // A start near or over the limit is judged as the safety monitor
        // judges the real rover's (`tilt_stop_deg`): with the plain limit
        // every way off a slope read as a tip-over at once, and the lava
        // tube's rover, stopped at 30.1 degrees on the muddy entrance, was
        // stranded there. Settling on a steep slope rocks the model by a
        // few degrees: the start's tilt is taken once it has settled.
        if self.step == 1 && self.leg == Leg::Nominal {
            self.start_tilt_deg = tilt;
        }
        if self.step == 1 && tilt_stop_deg(tip, tilt) > tip {
            self.tilt_limit_deg = tilt_stop_deg(tip, f64::INFINITY);
            self.tilted_start = true;
        } else if self.step == settle_steps && self.tilted_start {
            self.tilt_limit_deg = tilt_stop_deg(tip, tilt);
        }
        if tilt > self.tilt_limit_deg {
            return self.verdict_now(Outcome::TippedOver);
        }
        if rover.falls > 0 {
            return self.verdict_now(Outcome::Fell);
        }
        if self.too_steep_for_grip(tilt) {
            return self.verdict_now(Outcome::TooSteepForGrip);
        }
        if !s.position.iter().all(|v| v.is_finite()) || s.position[2] < self.terrain.lo[2] - 1.0 {
            return self.verdict_now(Outcome::NoGround);
        }
        if self.step > settle_steps && self.follower.done() {
            let e = self.goal_error();
            let outcome = if e > self.p.goal_tolerance_m {
                Outcome::Missed
            } else if self.overhangs() {
                Outcome::Overhang
            } else {
                Outcome::Reached
            };
            if outcome == Outcome::Reached && self.way_back_due() {
                self.begin_way_back(t, [x, y], yaw);
                return None;
            }
            return self.verdict_now(outcome);
        }
        let turned = (yaw - self.anchor.2 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        if (x - self.anchor.1[0]).hypot(y - self.anchor.1[1]) > self.p.stuck_progress_m
            || turned.abs() > STUCK_TURN_RAD
        {
            self.anchor = (t, [x, y], yaw);
        } else if self.step > settle_steps && t - self.anchor.0 > self.p.stuck_after_s {
            return self.verdict_now(Outcome::Stuck);
        }
        // Backward, the follower drives at a fraction of the speed.
        let (since, allowed) = match self.returning {
            Some((r, _)) => (Some(r), self.time_allowed_s / REVERSE_SPEED_SCALE),
            None => (self.moving_since, self.time_allowed_s),
        };
        let driving_s = since.map_or(0.0, |m| (self.step - m) as f64 * dt);
        let waited = self.returning.is_none() && t > self.p.settle_s + self.time_allowed_s;
        if waited || driving_s > allowed {
            return self.verdict_now(Outcome::Timeout);
        }
        None
    }

    /// Whether the rover, tilted `tilt` deg, stands on ground sloping
    /// more than its read grip allows: the slope under its wheels, not the
    /// body's tilt, which pitches a few degrees more as it starts and
    /// brakes. A rover that started within [`GRIP_EXEMPT_DEG`] of the
    /// limit is not judged so: every way off the slope must stay open,
    /// and a plan that brought it there must be able to take it back.
    fn too_steep_for_grip(&self, tilt: f64) -> bool {
        let limit = self.p.low_grip_max_tilt_deg;
        if limit <= 0.0 || tilt <= limit || self.start_tilt_deg > limit - GRIP_EXEMPT_DEG {
            return false;
        }
        let Some(rover) = &self.rover else {
            return false;
        };
        let depth = rover.ground_under_hubs(self.p.physics.wheel_radius_m + GROUND_PROBE_M);
        let hubs = rover.hubs();
        let mut ground = [[0.0; 3]; 4];
        for w in 0..4 {
            let Some(d) = depth[w] else {
                return false;
            };
            ground[w] = [hubs[w][0], hubs[w][1], hubs[w][2] - d];
        }
        // The diagonals FR-RL and FL-RR span the plane the wheels stand on.
        let a = [0, 1, 2].map(|k| ground[1][k] - ground[2][k]);
        let b = [0, 1, 2].map(|k| ground[0][k] - ground[3][k]);
        let n = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if len <= 0.0 || !len.is_finite() {
            return false;
        }
        let up = n.map(|c| c / len * n[2].signum());
        let slope = up[2].clamp(-1.0, 1.0).acos().to_degrees();
        if slope <= limit {
            return false;
        }
        let centre = [0, 1, 2].map(|k| ground.iter().map(|g| g[k]).sum::<f64>() / 4.0);
        self.terrain.reads_low_grip(centre, up, GROUND_BELOW_VOXELS)
    }

    /// Whether a wheel stands over an edge of the ground built: what the
    /// rover may pass over, but should not stop on.
    fn overhangs(&self) -> bool {
        let (Some(r), d) = (&self.rover, self.p.overhang_depth_m) else {
            return false;
        };
        d > 0.0
            && r.ground_under_hubs(self.p.physics.wheel_radius_m + d)
                .iter()
                .any(Option::is_none)
    }

    /// How far the rover rose above its start on the way predicted, m.
    fn climbed_m(&self) -> f64 {
        let points = self.prediction();
        let Some(first) = points.first() else {
            return 0.0;
        };
        points.iter().map(|p| p[2] - first[2]).fold(0.0, f64::max)
    }

    /// Whether the goal just reached calls for the way back: asked for,
    /// not driven yet, and the rover went down on the way.
    fn way_back_due(&self) -> bool {
        let points = self.prediction();
        if !self.way_back || self.returning.is_some() || points.is_empty() {
            return false;
        }
        let lowest = points.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min);
        lowest < points[0][2] - self.p.way_back_drop_m
    }

    /// The plan reversed, to the start, each pose keeping its heading:
    /// driven backward, without turning round on the slope.
    fn begin_way_back(&mut self, t: f64, at: [f64; 2], yaw: f64) {
        let plan = Verdict {
            outcome: Outcome::Reached,
            drive_s: self
                .moving_since
                .map_or(0.0, |s| (self.step - s) as f64 * self.p.dt_s),
            goal_error_m: self.goal_error(),
        };
        self.returning = Some((self.step, plan));
        self.plan.reverse();
        let [x, y, z, heading] = self.start.xyz_yaw();
        if self.plan.is_full() {
            self.plan.pop();
        }
        let _ = self.plan.push([x, y, z - self.p.base_height_m, heading]);
        let poses = self.plan.iter().map(|q| [q[0], q[1], q[3]]);
        self.follower.set_plan(poses);
        self.anchor = (t, at, yaw);
    }

    fn verdict_now(&mut self, outcome: Outcome) -> Option<Verdict> {
        self.phase = self.finish(outcome);
        self.verdict
    }
}

/// The rover's build with no surface gripping more than the pessimistic
/// rollout's friction, or than what holds the rover standing at `start`
/// (on a slope of angle a, at least tan a: it stands there, it does not
/// slide).
fn pessimistic_physics(p: &SimulatorParams, start: &Stance) -> PhysicsParams {
    let tilt = start.up()[2].clamp(-1.0, 1.0).acos();
    let mu = p.pessimistic_friction.max(tilt.tan());
    let ph = &p.physics;
    PhysicsParams {
        friction_rock: ph.friction_rock.min(mu),
        friction_mud: ph.friction_mud.min(mu),
        friction_concrete: ph.friction_concrete.min(mu),
        ..ph.clone()
    }
}

/// Distance from `c` to the segment `a`-`b`, in x and y.
fn segment_distance(c: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((c[0] - a[0]) * dx + (c[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (c[0] - a[0] - t * dx).hypot(c[1] - a[1] - t * dy)
}
