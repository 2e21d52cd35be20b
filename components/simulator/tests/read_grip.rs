//! The ground's grip read from its returns: a climb steeper than mud
//! holds is refused where the slope reads as mud and passed where it
//! reads as rock, whatever the incidence the returns came at; with the
//! reading off every surface grips as rock; mud under the tilt limit and
//! a way down off a steep mud slope are still driven.

use speleo_simulator::{CloudSource, InternalSim, Outcome, SimulatorParams, Stance};

/// Level for a metre, then up at 22 degrees (more than mud's 0.35 holds,
/// less than rock's 0.8).
fn ramp(x: f64) -> f64 {
    (x - 1.0).max(0.0) * 22f64.to_radians().tan()
}

/// Level for a metre, then up at 8 degrees (under the tilt limit on mud).
fn gentle(x: f64) -> f64 {
    (x - 1.0).max(0.0) * 8f64.to_radians().tan()
}

/// Level for a metre, then up at 15 degrees (within both rock's and
/// mud's grip).
fn rock_slope(x: f64) -> f64 {
    (x - 1.0).max(0.0) * 15f64.to_radians().tan()
}

fn level(_: f64) -> f64 {
    0.0
}

/// Rock's reflectance and mud's, as the sensor twin models them.
const ROCK: f64 = 60.0;
const MUD: f64 = 25.0;

/// Scans of ground `z(x)` of `reflectance` from sensors `height` m over
/// it along y = 0 at `xs`, each return as bright as the sensor twin makes
/// it (the reflectance times 0.2 + 0.8 cos of the incidence).
struct Scans {
    origins: Vec<[f64; 3]>,
    points: Vec<Vec<[f64; 3]>>,
    intensities: Vec<Vec<u8>>,
}

impl Scans {
    fn new(z: fn(f64) -> f64, reflectance: f64, xs: &[f64], height: f64) -> Scans {
        let mut origins = Vec::new();
        let mut points = Vec::new();
        let mut intensities = Vec::new();
        for &ox in xs {
            let o = [ox, 0.0, z(ox) + height];
            origins.push(o);
            let mut pts = Vec::new();
            let mut lum = Vec::new();
            for i in 0..160 {
                let x = -2.0 + 0.05 * i as f64;
                let slope = (z(x + 0.01) - z(x - 0.01)) / 0.02;
                let n = [-slope, 0.0, 1.0].map(|c| c / (1.0 + slope * slope).sqrt());
                for j in 0..60 {
                    let p = [x, -1.5 + 0.05 * j as f64, z(x)];
                    let d = [0, 1, 2].map(|k| p[k] - o[k]);
                    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    let cos = ((d[0] * n[0] + d[1] * n[1] + d[2] * n[2]) / len).abs();
                    pts.push(p);
                    lum.push((reflectance * (0.2 + 0.8 * cos)).round().clamp(1.0, 255.0) as u8);
                }
            }
            points.push(pts);
            intensities.push(lum);
        }
        Scans {
            origins,
            points,
            intensities,
        }
    }

    /// Sensors 1 m over the ground every 1.5 m along the plan.
    fn along(z: fn(f64) -> f64, reflectance: f64) -> Scans {
        Scans::new(z, reflectance, &[-1.0, 0.5, 2.0, 3.5], 1.0)
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
        let all = &self.intensities[k];
        let to = (from + n).min(all.len());
        out.extend_from_slice(&all[from.min(to)..to]);
    }
}

/// The verdict on a plan from `x0` to `x1` along x over the ground the
/// scans saw, with the reading at `low_grip_reflectance`.
fn verdict(
    z: fn(f64) -> f64,
    scans: &Scans,
    low_grip_reflectance: f64,
    x0: f64,
    x1: f64,
) -> Outcome {
    let p = SimulatorParams {
        low_grip_reflectance,
        ..SimulatorParams::default()
    };
    verdict_with(p, z, scans, x0, x1)
}

/// The verdict on that plan with the simulator's settings `p` (the
/// pessimistic rollout off).
fn verdict_with(p: SimulatorParams, z: fn(f64) -> f64, scans: &Scans, x0: f64, x1: f64) -> Outcome {
    let p = SimulatorParams {
        pessimistic_friction: 0.0,
        ..p
    };
    let base = p.base_height_m;
    let mut sim = InternalSim::new(p).expect("sim");
    let plan = (0..=40)
        .map(|i| {
            let x = x0 + (x1 - x0) * i as f64 / 40.0;
            [
                x,
                0.0,
                z(x),
                if x1 >= x0 { 0.0 } else { std::f64::consts::PI },
            ]
        })
        .collect::<Vec<_>>();
    let heading = plan[0][3];
    let start = if z(x0) == 0.0 {
        Stance::level(x0, 0.0, base, heading)
    } else {
        let pitch = -(z(x0 + 0.01) - z(x0 - 0.01)).atan2(0.02) * heading.cos();
        Stance {
            position: [x0, 0.0, z(x0) + base],
            yaw: heading,
            pitch,
            roll: 0.0,
        }
    };
    sim.begin(start, plan);
    let mut steps = 0;
    loop {
        if let Some(v) = sim.step(scans, 64) {
            return v.outcome;
        }
        steps += 1;
        assert!(steps < 2_000_000, "no verdict");
    }
}

#[test]
fn a_climb_too_steep_for_mud_is_refused_where_it_reads_as_mud_and_passed_on_rock() {
    assert_eq!(
        verdict(ramp, &Scans::along(ramp, ROCK), 40.0, 0.0, 4.0),
        Outcome::Reached,
        "rock's grip holds 22 degrees"
    );
    let mud = Scans::along(ramp, MUD);
    let on_mud = verdict(ramp, &mud, 40.0, 0.0, 4.0);
    assert_ne!(
        on_mud,
        Outcome::Reached,
        "mud's grip does not hold 22 degrees"
    );
    // Under the slope, the limit refuses the climb before the grip does.
    let p = SimulatorParams {
        low_grip_max_tilt_deg: 18.0,
        ..SimulatorParams::default()
    };
    assert_eq!(
        verdict_with(p, ramp, &mud, 0.0, 4.0),
        Outcome::TooSteepForGrip
    );
}

#[test]
fn rock_seen_only_at_grazing_incidence_reads_as_rock() {
    // From 6 m back and 0.6 m up, the level part is seen at 80-85
    // degrees off its normal: it returns under mud's 25.
    let far = Scans::new(rock_slope, ROCK, &[-8.0, -7.0, -6.0], 0.6);
    assert_eq!(verdict(rock_slope, &far, 40.0, 0.0, 4.0), Outcome::Reached);
}

#[test]
fn with_the_reading_off_every_surface_grips_as_rock() {
    assert_eq!(
        verdict(ramp, &Scans::along(ramp, MUD), 0.0, 0.0, 4.0),
        Outcome::Reached
    );
}

#[test]
fn mud_under_the_tilt_limit_is_driven() {
    assert_eq!(
        verdict(level, &Scans::along(level, MUD), 40.0, 0.0, 4.0),
        Outcome::Reached
    );
    assert_eq!(
        verdict(gentle, &Scans::along(gentle, MUD), 40.0, 0.0, 4.0),
        Outcome::Reached
    );
}

#[test]
fn a_way_down_off_a_mud_slope_steeper_than_the_limit_is_not_refused_for_its_grip() {
    // With the limit under the slope, from the foot the climb is refused,
    // from up the slope the way down is not.
    let p = SimulatorParams {
        low_grip_max_tilt_deg: 12.0,
        ..SimulatorParams::default()
    };
    let scans = Scans::along(rock_slope, MUD);
    assert_eq!(
        verdict_with(p.clone(), rock_slope, &scans, 0.0, 3.5),
        Outcome::TooSteepForGrip
    );
    let down = verdict_with(p, rock_slope, &scans, 3.0, 0.0);
    assert_ne!(down, Outcome::TooSteepForGrip);
}
