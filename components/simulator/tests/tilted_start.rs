//! The simulated rover starts as the real one stands: tilted on a side
//! slope whose ground under the rover the scans never saw, it is not put
//! down level on a shelf cut into the slope.

use speleo_control::safety::{tilt_stop_deg, TILT_GROWTH_DEG};
use speleo_physics::quat;
use speleo_simulator::{CloudSource, InternalSim, Outcome, SimulatorParams, Stance};

/// Side slope angle, rad (about 20°): rising toward +y.
const SLOPE: f64 = 0.36;

fn ground(y: f64) -> f64 {
    SLOPE.tan() * y
}

/// The slope scanned from sensors along y = 0, every 5 cm, except within
/// 0.7 m of the rover at the origin (its own mast hides that ground).
struct SideSlope {
    origins: Vec<[f64; 3]>,
    points: Vec<[f64; 3]>,
}

impl SideSlope {
    fn new() -> Self {
        let mut points = Vec::new();
        for i in 0..200 {
            let x = -2.0 + 0.05 * i as f64;
            for j in 0..70 {
                let y = -1.75 + 0.05 * j as f64;
                if x.hypot(y) > 0.7 {
                    points.push([x, y, ground(y)]);
                }
            }
        }
        let origins = [-1.0, 1.0, 3.0, 5.0].map(|x| [x, 0.0, 1.0]).to_vec();
        SideSlope { origins, points }
    }
}

impl CloudSource for SideSlope {
    fn keyframes(&self) -> usize {
        self.origins.len()
    }
    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        self.origins.get(k).copied()
    }
    fn points(&self, _: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        out.clear();
        let to = (from + n).min(self.points.len());
        out.extend_from_slice(&self.points[from.min(to)..to]);
        to < self.points.len()
    }
}

/// The simulated rover's tilt, deg, a second into the drive, with
/// `start_tilted` on or off, and starting tilted anyway over `over_deg`.
fn tilt_after_a_second(start: Stance, start_tilted: bool, over_deg: f64) -> f64 {
    let p = SimulatorParams {
        start_tilted,
        start_tilted_over_deg: over_deg,
        ..SimulatorParams::default()
    };
    let mut sim = InternalSim::new(p.clone()).expect("sim");
    let plan: Vec<[f64; 4]> = (0..=30).map(|i| [0.1 * i as f64, 0.0, 0.0, 0.0]).collect();
    sim.begin(start, plan);
    let scans = SideSlope::new();
    let mut driving_steps = 0;
    for _ in 0..2_000_000 {
        if sim.work() == "drive" {
            driving_steps += 1;
        }
        if driving_steps * 10 >= 1000 || sim.step(&scans, 1).is_some() {
            break;
        }
    }
    let s = sim.rover_state().expect("the rover is in the world");
    let up = quat::rotate(&s.orientation, [0.0, 0.0, 1.0]);
    up[2].clamp(-1.0, 1.0).acos().to_degrees()
}

/// The rover at the origin as it stands on the slope (base_link over the
/// ground, square to it), and the same put down level.
fn stances() -> (Stance, Stance) {
    let z = SimulatorParams::default().base_height_m / SLOPE.cos();
    let level = Stance::level(0.0, 0.0, z, 0.0);
    let tilted = Stance {
        roll: SLOPE,
        ..level
    };
    (tilted, level)
}

#[test]
fn a_rover_tilted_on_a_slope_starts_tilted_in_the_simulation() {
    let (tilted, level_stance) = stances();
    let never = 90.0;
    let tilt = tilt_after_a_second(tilted, true, never);
    assert!(
        (tilt - SLOPE.to_degrees()).abs() < 4.0,
        "{tilt:.1} deg on a {:.1} deg slope",
        SLOPE.to_degrees()
    );
    // Put down level (the stance level, or the tilted start off): it
    // stands on a shelf cut into the slope, far less tilted than it is.
    let level = tilt_after_a_second(level_stance, true, never);
    assert_eq!(
        tilt_after_a_second(tilted, false, never).to_bits(),
        level.to_bits()
    );
    assert!(level < tilt - 8.0, "level {level:.1}, tilted {tilt:.1}");
}

#[test]
fn with_the_tilted_start_off_a_rover_tilted_past_the_threshold_still_starts_tilted() {
    let (tilted, level_stance) = stances();
    let as_it_stands = tilt_after_a_second(tilted, true, 90.0);
    let level = tilt_after_a_second(level_stance, false, 90.0);
    // About 20 degrees of roll: over a 15-degree threshold, as it stands...
    let over = tilt_after_a_second(tilted, false, 15.0);
    assert_eq!(over.to_bits(), as_it_stands.to_bits(), "{over:.1}");
    // ...under a 25-degree one, level.
    let under = tilt_after_a_second(tilted, false, 25.0);
    assert_eq!(under.to_bits(), level.to_bits(), "{under:.1}");
}

/// The verdict on a 3 m drive along the slope from where the rover stands
/// on it, with the tilt limit `limit_deg`: the outcome, and when, s (the
/// nominal rollout's rule alone; `tests/pessimistic.rs` has the other).
fn along_the_slope(limit_deg: f64) -> (Outcome, u64) {
    let p = SimulatorParams {
        tip_over_deg: limit_deg,
        pessimistic_friction: 0.0,
        ..SimulatorParams::default()
    };
    let mut sim = InternalSim::new(p).expect("sim");
    let plan: Vec<[f64; 4]> = (0..=30).map(|i| [0.1 * i as f64, 0.0, 0.0, 0.0]).collect();
    sim.begin(stances().0, plan);
    let scans = SideSlope::new();
    for _ in 0..2_000_000 {
        if let Some(v) = sim.step(&scans, 64) {
            return (v.outcome, v.drive_s.to_bits());
        }
    }
    panic!("no verdict");
}

#[test]
fn a_start_near_or_over_the_tilt_limit_is_judged_by_the_safety_monitors_rule() {
    let start = SLOPE.to_degrees();
    // Begun over the limit (where the monitor stopped the real rover), it
    // may drive on while its tilt grows by no more than the growth; the
    // leg-wheels rock it past that on this drive.
    let over = along_the_slope(start - 1.0);
    assert_eq!(over.0, Outcome::TippedOver);
    // Begun within the growth under the limit, the monitor lets the real
    // rover tilt as far, and the simulation stops it there, not sooner.
    for d in [0.2, 1.0] {
        assert_eq!(tilt_stop_deg(start + d, start), start + TILT_GROWTH_DEG);
        assert_eq!(along_the_slope(start + d), over, "limit {d} over the start");
    }
    // Far under the limit it is the limit, and this drive keeps under it.
    assert_eq!(along_the_slope(start + 8.0).0, Outcome::Reached);
}
