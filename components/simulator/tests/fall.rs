//! Falls in the internal simulation. Down a 0.15 m step the rover drives
//! on and reaches the goal; driven off a metre's ledge it noses over past
//! the tilt limit before it sinks fast (tipped over); put down a metre
//! over the ground (its estimated height wrong by that much) it falls
//! flat, and the plan is refused as a fall.

mod common;

use common::{run_to_verdict, step_down, straight_plan};
use speleo_physics::{Material, Mesh};
use speleo_simulator::{InternalSim, Outcome, SimulatorParams, Stance, Verdict};

/// From the origin along x to 4 m, over the edge at 1.5 m, on `ground`.
fn drive(ground: Mesh, drop: f64) -> Verdict {
    let p = SimulatorParams::default();
    let start = Stance::level(0.0, 0.0, p.base_height_m, 0.0);
    let mut sim = InternalSim::new(p).expect("sim");
    sim.begin_on(start, straight_plan(4.0, 1.5, drop), ground);
    run_to_verdict(&mut sim)
}

#[test]
fn a_rover_that_falls_is_refused_and_one_down_a_step_passes() {
    let step = drive(step_down(0.0, 1.5, 0.15, Material::Concrete), 0.15);
    assert_eq!(step.outcome, Outcome::Reached, "{step:?}");
    let off = drive(step_down(0.0, 1.5, 1.0, Material::Concrete), 1.0);
    assert_eq!(off.outcome, Outcome::TippedOver, "{off:?}");
    // The ground a metre under where the rover was put down.
    let flat = drive(step_down(-1.0, 1.5, 0.0, Material::Concrete), 0.0);
    assert_eq!(flat.outcome, Outcome::Fell, "{flat:?}");
    assert_eq!(flat.drive_s, 0.0, "{flat:?}");
}
