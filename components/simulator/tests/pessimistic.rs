//! The pessimistic rollout: a plan passes only if it also passes on
//! ground of the lowest grip the rover may meet, started as the rover
//! stands, with a margin under the tip limit.

mod common;

use common::run_to_verdict;
use speleo_physics::{Material, Mesh};
use speleo_simulator::{InternalSim, Outcome, SimulatorParams, Stance, Verdict};
use speleo_twin::world::shapes::add_hexahedron;

/// A floor up to x = 0, then a rock slope rising along +x at `deg` for
/// 5 m, 6 m wide; when `across`, a floor from x = -6 to 8 that is level
/// at x = -6 and twists to rise along +y at `deg` by x = 8.
fn slope(deg: f64, across: bool) -> Mesh {
    let rise = (5.0 * deg.to_radians().tan()) as f32;
    let mut m = Mesh::default();
    if across {
        // Rising along +y from y = -3 to y = 2.
        add_hexahedron(
            &mut m,
            [
                [-6.0, -3.0, -1.0],
                [8.0, -3.0, -1.0],
                [8.0, 2.0, -1.0],
                [-6.0, 2.0, -1.0],
                [-6.0, -3.0, 0.0],
                [8.0, -3.0, 0.0],
                [8.0, 2.0, rise],
                [-6.0, 2.0, 0.0],
            ],
            Material::Rock,
        );
        return m;
    }
    add_hexahedron(
        &mut m,
        [
            [-4.0, -3.0, -1.0],
            [0.0, -3.0, -1.0],
            [0.0, 3.0, -1.0],
            [-4.0, 3.0, -1.0],
            [-4.0, -3.0, 0.0],
            [0.0, -3.0, 0.0],
            [0.0, 3.0, 0.0],
            [-4.0, 3.0, 0.0],
        ],
        Material::Rock,
    );
    add_hexahedron(
        &mut m,
        [
            [0.0, -3.0, -1.0],
            [5.0, -3.0, -1.0],
            [5.0, 3.0, -1.0],
            [0.0, 3.0, -1.0],
            [0.0, -3.0, 0.0],
            [5.0, -3.0, rise],
            [5.0, 3.0, rise],
            [0.0, 3.0, 0.0],
        ],
        Material::Rock,
    );
    m
}

/// Straight along +x from `x0` to `x1`, on `ground`, starting as the
/// ground tilts the rover there.
fn drive(
    p: SimulatorParams,
    mesh: Mesh,
    x0: f64,
    x1: f64,
    ground: impl Fn(f64) -> f64,
    pitch: f64,
    roll: f64,
) -> Verdict {
    let start = Stance {
        position: [x0, 0.0, ground(x0) + p.base_height_m],
        yaw: 0.0,
        pitch,
        roll,
    };
    let n = ((x1 - x0) / 0.1).round() as usize;
    let plan: Vec<[f64; 4]> = (0..=n)
        .map(|i| {
            let x = x0 + 0.1 * i as f64;
            [x, 0.0, ground(x), 0.0]
        })
        .collect();
    let mut sim = InternalSim::new(p).expect("sim");
    sim.begin_on(start, plan, mesh);
    let v = run_to_verdict(&mut sim);
    assert_eq!(
        sim.refused_when_pessimistic(),
        v.outcome != Outcome::Reached && sim.params().pessimistic_friction > 0.0,
        "{v:?}"
    );
    v
}

#[test]
fn a_climb_the_rover_makes_on_rock_but_not_in_mud_is_refused() {
    // 22 degrees: rock (0.8) holds the legs, mud (0.35, 19 degrees of
    // grip) does not.
    let a = 22f64.to_radians();
    let ground = |x: f64| x.clamp(0.0, 5.0) * a.tan();
    let nominal = SimulatorParams {
        pessimistic_friction: 0.0,
        ..SimulatorParams::default()
    };
    let up = drive(nominal, slope(22.0, false), -1.5, 3.0, ground, 0.0, 0.0);
    assert_eq!(up.outcome, Outcome::Reached, "{up:?}");
    let mud = SimulatorParams {
        pessimistic_friction: 0.35,
        ..SimulatorParams::default()
    };
    let both = drive(mud, slope(22.0, false), -1.5, 3.0, ground, 0.0, 0.0);
    assert_ne!(both.outcome, Outcome::Reached, "{both:?}");
}

#[test]
fn a_traverse_within_the_tip_limit_but_not_its_margin_is_refused() {
    // Onto a side slope that steepens to 20 degrees: the roll grows to
    // about 19 degrees, under a 30 degree limit, over it less a 14 degree
    // margin. The grip is left as it is, to judge the tilt alone.
    let rise = 5.0 * 20f64.to_radians().tan();
    let ground = |x: f64| 0.6 * rise * (x + 6.0) / 14.0;
    let p = |margin: f64| SimulatorParams {
        tip_over_deg: 30.0,
        pessimistic_friction: 2.0,
        pessimistic_tilt_margin_deg: margin,
        ..SimulatorParams::default()
    };
    let within = drive(p(0.0), slope(20.0, true), -4.0, 7.0, ground, 0.0, 0.0);
    assert_eq!(within.outcome, Outcome::Reached, "{within:?}");
    let margin = drive(p(14.0), slope(20.0, true), -4.0, 7.0, ground, 0.0, 0.0);
    assert_eq!(margin.outcome, Outcome::TippedOver, "{margin:?}");
}
