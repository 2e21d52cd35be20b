//! A goal at a roof's rim: the plan ends with the rover's side over the
//! edge, its centre on the roof. It reaches the goal, but stands there
//! with two wheels over nothing: refused as an overhang, unless the
//! check is off; a goal a body's width in from the rim passes.

mod common;

use common::run_to_verdict;
use speleo_physics::{Material, Mesh};
use speleo_simulator::{InternalSim, Outcome, SimulatorParams, Stance, Verdict};
use speleo_twin::world::shapes::add_box;

/// A roof up to y = 0.5, and a floor 9 m under it beyond.
fn roof() -> Mesh {
    let mut m = Mesh::default();
    add_box(
        &mut m,
        [-3.0, -3.0, -1.0],
        [8.0, 0.5, 0.0],
        Material::Concrete,
    );
    add_box(
        &mut m,
        [-3.0, 0.5, -10.0],
        [8.0, 4.0, -9.0],
        Material::Concrete,
    );
    m
}

/// From the origin along x, drifting to `y_end` over the last 2 m.
fn plan(y_end: f64) -> Vec<[f64; 4]> {
    (0..=40)
        .map(|i| {
            let x = 0.1 * i as f64;
            let y = if x < 2.0 {
                0.0
            } else {
                y_end * (x - 2.0) / 2.0
            };
            [x, y, 0.0, 0.0]
        })
        .collect()
}

fn drive(y_end: f64, overhang_depth_m: f64) -> Verdict {
    let p = SimulatorParams {
        overhang_depth_m,
        ..SimulatorParams::default()
    };
    let start = Stance::level(0.0, 0.0, p.base_height_m, 0.0);
    let mut sim = InternalSim::new(p).expect("sim");
    sim.begin_on(start, plan(y_end), roof());
    run_to_verdict(&mut sim)
}

#[test]
fn a_goal_that_leaves_wheels_over_a_rim_is_refused_as_an_overhang() {
    // The goal 0.21 m from the rim: the left wheels' hubs, 0.26 m out
    // from the centre line, stand a few centimetres past it, the wheels
    // still on the edge. (A goal nearer the rim leaves the box's sharp
    // edge under the wheels, and the rover is stuck on it before.)
    let at_rim = drive(0.29, SimulatorParams::default().overhang_depth_m);
    assert_eq!(at_rim.outcome, Outcome::Overhang, "{at_rim:?}");
    // It got there: only the check refuses it.
    let unchecked = drive(0.29, 0.0);
    assert_eq!(unchecked.outcome, Outcome::Reached, "{unchecked:?}");
    assert_eq!(unchecked.goal_error_m, at_rim.goal_error_m);
    // A body's width in from the rim, the same plan's end passes.
    let inside = drive(-0.3, SimulatorParams::default().overhang_depth_m);
    assert_eq!(inside.outcome, Outcome::Reached, "{inside:?}");
}
