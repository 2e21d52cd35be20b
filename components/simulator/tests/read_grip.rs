//! The ground's grip read from its returns: a climb the wheels hold on
//! rock is refused where every return from the slope reads dark (mud's
//! grip), passed where it reads bright, and passed whatever it reads with
//! the reading off. Dark level ground is still driven.

use speleo_simulator::{CloudSource, InternalSim, Outcome, SimulatorParams, Stance};

/// Level for a metre, then up at 22 degrees (more than mud's 0.35 holds,
/// less than rock's 0.8).
fn ramp(x: f64) -> f64 {
    (x - 1.0).max(0.0) * 22f64.to_radians().tan()
}

fn level(_: f64) -> f64 {
    0.0
}

/// Scans of ground `z(x)` from sensors 1 m over it along y = 0, every
/// return reading `intensity`.
struct Scans {
    origins: Vec<[f64; 3]>,
    points: Vec<Vec<[f64; 3]>>,
    intensity: u8,
}

impl Scans {
    fn new(z: fn(f64) -> f64, intensity: u8) -> Scans {
        let mut origins = Vec::new();
        let mut points = Vec::new();
        for s in 0..4 {
            let ox = -1.0 + 1.5 * s as f64;
            origins.push([ox, 0.0, z(ox) + 1.0]);
            let mut pts = Vec::new();
            for i in 0..160 {
                let x = -2.0 + 0.05 * i as f64;
                for j in 0..60 {
                    pts.push([x, -1.5 + 0.05 * j as f64, z(x)]);
                }
            }
            points.push(pts);
        }
        Scans {
            origins,
            points,
            intensity,
        }
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
        out.clear();
        let all = &self.points[k];
        let to = (from + n).min(all.len());
        out.extend_from_slice(&all[from.min(to)..to]);
        to < all.len()
    }
    fn intensities(&self, k: usize, from: usize, n: usize, out: &mut Vec<u8>) {
        out.clear();
        let to = (from + n).min(self.points[k].len());
        out.resize(to.saturating_sub(from), self.intensity);
    }
}

/// The verdict on a plan 4 m along x over `z`, read at `intensity`.
fn verdict(z: fn(f64) -> f64, intensity: u8, low_grip_intensity: f64) -> Outcome {
    let p = SimulatorParams {
        low_grip_intensity,
        pessimistic_friction: 0.0,
        ..SimulatorParams::default()
    };
    let base = p.base_height_m;
    let mut sim = InternalSim::new(p).expect("sim");
    let plan = (0..=40)
        .map(|i| {
            let x = 0.1 * i as f64;
            [x, 0.0, z(x), 0.0]
        })
        .collect::<Vec<_>>();
    sim.begin(Stance::level(0.0, 0.0, z(0.0) + base, 0.0), plan);
    let scans = Scans::new(z, intensity);
    let mut steps = 0;
    loop {
        if let Some(v) = sim.step(&scans, 64) {
            return v.outcome;
        }
        steps += 1;
        assert!(steps < 2_000_000, "no verdict");
    }
}

#[test]
fn a_climb_whose_slope_reads_dark_is_refused_and_bright_passes() {
    assert_eq!(
        verdict(ramp, 60, 26.0),
        Outcome::Reached,
        "rock's grip holds 22 degrees"
    );
    let dark = verdict(ramp, 20, 26.0);
    assert!(
        matches!(dark, Outcome::Stuck | Outcome::Timeout),
        "mud's grip does not hold 22 degrees: {dark:?}"
    );
}

#[test]
fn with_the_reading_off_every_surface_grips_as_rock() {
    assert_eq!(verdict(ramp, 20, 0.0), Outcome::Reached);
}

#[test]
fn dark_level_ground_is_still_driven() {
    assert_eq!(verdict(level, 20, 26.0), Outcome::Reached);
}
