//! The internal simulator on synthetic maps: flat ground is driven to the
//! goal, a ledge the rover cannot climb is refused, and the same inputs
//! give the same verdict and prediction.

use speleo_simulator::{CloudSource, InternalSim, Outcome, SimulatorParams, Stance};

/// Scans taken from sensors 1 m over the ground along y = 0, of ground
/// `z(x)` with a vertical face wherever it jumps.
struct Scans {
    origins: Vec<[f64; 3]>,
    points: Vec<Vec<[f64; 3]>>,
}

impl Scans {
    fn new(z: impl Fn(f64) -> f64) -> Scans {
        let mut origins = Vec::new();
        let mut points = Vec::new();
        for s in 0..5 {
            let ox = -1.0 + 2.0 * s as f64;
            let o = [ox, 0.0, z(ox) + 1.0];
            let mut pts = Vec::new();
            for i in 0..200 {
                let x = -2.0 + 0.05 * i as f64;
                for j in 0..60 {
                    let y = -1.5 + 0.05 * j as f64;
                    pts.push([x, y, z(x)]);
                    // The face between this column and the next.
                    let (a, b) = (z(x), z(x + 0.05));
                    let mut h = a.min(b) + 0.05;
                    while h < a.max(b) {
                        pts.push([x + 0.025, y, h]);
                        h += 0.05;
                    }
                }
            }
            origins.push(o);
            points.push(pts);
        }
        Scans { origins, points }
    }
}

impl CloudSource for Scans {
    fn keyframes(&self) -> usize {
        self.origins.len()
    }
    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        self.origins.get(k).copied()
    }
    fn points(&self, k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        serve(&self.points[k], from, n, out)
    }
}

/// Up to `n` of `points` from `from` into `out`; whether more are left.
fn serve(points: &[[f64; 3]], from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
    out.clear();
    let to = (from + n).min(points.len());
    out.extend_from_slice(&points[from.min(to)..to]);
    to < points.len()
}

fn plan(z: impl Fn(f64) -> f64) -> Vec<[f64; 4]> {
    plan_to(5.0, z)
}

/// Straight along x from 0 to `end`.
fn plan_to(end: f64, z: impl Fn(f64) -> f64) -> Vec<[f64; 4]> {
    let n = (end / 0.1).round() as usize;
    (0..=n)
        .map(|i| {
            let x = 0.1 * i as f64;
            [x, 0.0, z(x), 0.0]
        })
        .collect()
}

fn validate(z: impl Fn(f64) -> f64 + Copy) -> (Outcome, Vec<[f64; 3]>, f64) {
    validate_plan(z, plan(z))
}

fn validate_plan(
    z: impl Fn(f64) -> f64 + Copy,
    plan: Vec<[f64; 4]>,
) -> (Outcome, Vec<[f64; 3]>, f64) {
    let mut sim = InternalSim::new(SimulatorParams::default()).expect("sim");
    run(&mut sim, z, plan, 32)
}

/// One validation in `sim`, in steps of `units`.
fn run(
    sim: &mut InternalSim,
    z: impl Fn(f64) -> f64 + Copy,
    plan: Vec<[f64; 4]>,
    units: usize,
) -> (Outcome, Vec<[f64; 3]>, f64) {
    run_on(sim, &Scans::new(z), z(0.0), plan, units)
}

/// One validation in `sim` on `scans`, the rover standing on ground at
/// height `ground` at the origin.
fn run_on(
    sim: &mut InternalSim,
    scans: &impl CloudSource,
    ground: f64,
    plan: Vec<[f64; 4]>,
    units: usize,
) -> (Outcome, Vec<[f64; 3]>, f64) {
    let p = SimulatorParams::default();
    sim.begin(Stance::level(0.0, 0.0, ground + p.base_height_m, 0.0), plan);
    let mut steps = 0;
    let v = loop {
        if let Some(v) = sim.step(scans, units) {
            break v;
        }
        steps += 1;
        assert!(steps < 2_000_000, "no verdict");
    };
    (v.outcome, sim.prediction().to_vec(), v.goal_error_m)
}

#[test]
fn a_validation_does_not_depend_on_its_steps_units_or_the_world_before() {
    let flat = |_: f64| 0.0;
    let bumpy = |x: f64| if x > 2.0 { 0.08 } else { 0.0 };
    let mut sim = InternalSim::new(SimulatorParams::default()).expect("sim");
    let whole = run(&mut sim, flat, plan(flat), 100_000);
    // Another world in between: the next validation takes it down first.
    run(&mut sim, bumpy, plan(bumpy), 7);
    let sliced = run(&mut sim, flat, plan(flat), 1);
    assert_eq!(sliced.0, whole.0);
    assert_eq!(sliced.1, whole.1, "the same prediction");
    assert_eq!(sliced.2.to_bits(), whole.2.to_bits());
}

/// As a coprocessor drives it: the clouds only where they are read, the
/// rest in large batches without them.
#[test]
fn steps_without_the_clouds_stop_where_they_are_needed_and_change_nothing() {
    let bumpy = |x: f64| if x > 2.0 { 0.08 } else { 0.0 };
    let mut sim = InternalSim::new(SimulatorParams::default()).expect("sim");
    let whole = run(&mut sim, bumpy, plan(bumpy), 14);
    let scans = Scans::new(bumpy);
    let p = SimulatorParams::default();
    sim.begin(Stance::level(0.0, 0.0, p.base_height_m, 0.0), plan(bumpy));
    let (mut with, mut without) = (0, 0);
    let v = loop {
        let v = if sim.needs_clouds() {
            with += 1;
            sim.step(&scans, 14)
        } else {
            without += 1;
            sim.step_without_clouds(120)
        };
        if let Some(v) = v {
            break v;
        }
        assert!(with + without < 1_000_000, "no verdict");
    };
    assert!(with > 0 && without > 0, "{with} {without}");
    assert_eq!(v.outcome, whole.0);
    assert_eq!(sim.prediction(), &whole.1[..], "the same prediction");
    assert_eq!(v.goal_error_m.to_bits(), whole.2.to_bits());
}

#[test]
fn flat_ground_is_driven_to_the_goal_the_same_every_time() {
    let flat = |_: f64| 0.0;
    let (outcome, prediction, err) = validate(flat);
    assert_eq!(outcome, Outcome::Reached, "{err}");
    assert!(err < 0.5, "{err}");
    // From the start toward the goal 5 m on, at about the cruise speed.
    let last = prediction.last().copied().expect("prediction");
    assert!(last[0] > 4.3, "{last:?}");
    assert!(prediction.len() > 100, "{}", prediction.len());
    let again = validate(flat);
    assert_eq!(again.1, prediction);
}

#[test]
fn a_low_step_is_climbed() {
    let step = |x: f64| if x < 2.5 { 0.0 } else { 0.1 };
    let (outcome, _, err) = validate(step);
    assert_eq!(outcome, Outcome::Reached, "{err}");
}

#[test]
fn a_ledge_the_rover_cannot_climb_is_refused() {
    let ledge = |x: f64| if x < 2.5 { 0.0 } else { 0.45 };
    let (outcome, prediction, err) = validate(ledge);
    assert!(
        matches!(
            outcome,
            Outcome::Stuck | Outcome::Timeout | Outcome::TippedOver
        ),
        "{outcome:?} {err}"
    );
    eprintln!("ledge: {outcome:?}");
    // It drove up to the ledge.
    let last = prediction.last().copied().expect("prediction");
    assert!(last[0] > 1.5 && last[0] < 2.6, "{last:?}");
}

#[test]
fn a_goal_where_the_seen_floor_ends_is_reached() {
    // A frontier goal: the scans' floor ends at x = 8 and the goal lies at
    // its end (the planner bridges a ring gap there), so the rover's front
    // wheels stop over ground the map has not seen yet.
    let flat = |_: f64| 0.0;
    let (outcome, _, err) = validate_plan(flat, plan_to(8.2, flat));
    assert_eq!(outcome, Outcome::Reached, "{err}");
}

/// `Scans` of a floor at z = 0, and keyframes from the level under it
/// that see its underside at `underside_z` (a slab's underside, with the
/// drift SLAM leaves between two levels).
struct TwoLevels {
    top: Scans,
    under: Vec<([f64; 3], Vec<[f64; 3]>)>,
}

impl TwoLevels {
    fn new(underside_z: f64) -> TwoLevels {
        let mut under = Vec::new();
        for s in 0..5 {
            let o = [-1.0 + 2.0 * s as f64, 0.0, -2.3];
            let mut pts = Vec::new();
            for i in 0..200 {
                for j in 0..60 {
                    pts.push([-2.0 + 0.05 * i as f64, -1.5 + 0.05 * j as f64, underside_z]);
                }
            }
            under.push((o, pts));
        }
        TwoLevels {
            top: Scans::new(|_| 0.0),
            under,
        }
    }
}

impl CloudSource for TwoLevels {
    fn keyframes(&self) -> usize {
        self.top.keyframes() + self.under.len()
    }
    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        match k.checked_sub(self.top.keyframes()) {
            None => self.top.origin(k),
            Some(u) => self.under.get(u).map(|l| l.0),
        }
    }
    fn points(&self, k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        match k.checked_sub(self.top.keyframes()) {
            None => self.top.points(k, from, n, out),
            Some(u) => serve(&self.under[u].1, from, n, out),
        }
    }
}

#[test]
fn a_floor_also_seen_from_the_level_under_it_is_driven_on() {
    // A garage slab's underside seen from the level below 8 cm over its
    // top, as the two levels' SLAM poses put it (the rover's own estimate
    // drifted down on the way up): the rays from below carve the floor
    // away unless the world is built from the keyframes that can see the
    // floor the plan drives on (the rover was stuck in its holes).
    let scans = TwoLevels::new(0.08);
    let mut sim = InternalSim::new(SimulatorParams::default()).expect("sim");
    let (outcome, prediction, err) = run_on(&mut sim, &scans, 0.0, plan(|_| 0.0), 32);
    assert_eq!(outcome, Outcome::Reached, "{err}");
    // The simulated rover stayed on the floor's top.
    let z: Vec<f64> = prediction.iter().map(|q| q[2]).collect();
    let lowest = z.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(lowest > 0.0, "{lowest} {z:?}");
}

/// A flat floor from x = -3 to 12 and, from `ledge_x`, a block `ledge_h`
/// high (as a world mesh: ground given as it is).
fn floor_with_ledge(ledge_x: f32, ledge_h: f32) -> speleo_physics::Mesh {
    use speleo_physics::{Material, Mesh};
    use speleo_twin::world::shapes::add_box;
    let mut m = Mesh::default();
    add_box(
        &mut m,
        [-3.0, -3.0, -0.2],
        [ledge_x, 3.0, 0.0],
        Material::Rock,
    );
    add_box(
        &mut m,
        [ledge_x, -3.0, -0.2],
        [12.0, 3.0, ledge_h],
        Material::Rock,
    );
    m
}

#[test]
fn on_given_ground_a_plan_is_driven_as_on_the_clouds() {
    let p = SimulatorParams::default();
    let start = Stance::level(0.0, 0.0, p.base_height_m, 0.0);
    let drive = |ground| {
        let mut sim = InternalSim::new(SimulatorParams::default()).expect("sim");
        sim.begin_on(start, plan(|_| 0.0), ground);
        let mut n = 0;
        loop {
            if let Some(v) = sim.step_without_clouds(50) {
                break v.outcome;
            }
            n += 1;
            assert!(n < 1_000_000, "no verdict");
        }
    };
    assert_eq!(drive(floor_with_ledge(12.0, 0.0)), Outcome::Reached);
    assert_ne!(drive(floor_with_ledge(2.0, 0.45)), Outcome::Reached);
}

/// The same floor scanned on two passes whose poses SLAM has not yet
/// brought together: the first pass put it `offset` higher than the
/// second, which agrees with the rover's estimate.
struct TwoPasses {
    first: Scans,
    second: Scans,
}

impl CloudSource for TwoPasses {
    fn keyframes(&self) -> usize {
        self.first.keyframes() + self.second.keyframes()
    }
    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        match k.checked_sub(self.first.keyframes()) {
            None => self.first.origin(k),
            Some(s) => self.second.origin(s),
        }
    }
    fn points(&self, k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        match k.checked_sub(self.first.keyframes()) {
            None => self.first.points(k, from, n, out),
            Some(s) => self.second.points(s, from, n, out),
        }
    }
}

#[test]
fn the_world_is_made_of_the_newest_pass_over_a_place() {
    // 11 cm between the passes, as in the garage before a loop closure.
    let scans = TwoPasses {
        first: Scans::new(|_| 0.11),
        second: Scans::new(|_| 0.0),
    };
    let drive = |newest: usize| {
        let p = SimulatorParams {
            newest_keyframes: newest,
            ..SimulatorParams::default()
        };
        let mut sim = InternalSim::new(p).expect("sim");
        run_on(&mut sim, &scans, 0.0, plan(|_| 0.0), 32)
    };
    let base = SimulatorParams::default().base_height_m;
    // Worst height of the simulated rover over the second pass's floor.
    let off_floor = |prediction: &[[f64; 3]]| {
        prediction
            .iter()
            .map(|q| (q[2] - base).abs())
            .fold(0.0f64, f64::max)
    };
    // The newest five keyframes are the second pass: its floor alone.
    let (outcome, prediction, err) = drive(5);
    assert_eq!(outcome, Outcome::Reached, "{err}");
    assert!(off_floor(&prediction) < 0.03, "{}", off_floor(&prediction));
    // Both passes: a floor between the two.
    let (_, prediction, _) = drive(10);
    assert!(off_floor(&prediction) > 0.03, "{}", off_floor(&prediction));
}
