//! Falls in the internal simulation. Down a 0.15 m step the rover drives
//! on and reaches the goal; driven off a metre's ledge it noses over past
//! the tilt limit before it sinks fast (tipped over); put down a metre
//! over the ground (its estimated height wrong by that much) it falls
//! flat, and the plan is refused as a fall.

use speleo_hal::world::{shapes::add_box, Mesh, Surface};
use speleo_simulator::{InternalSim, Outcome, SimulatorParams, Stance, Verdict};

/// A floor up to x = 1.5 at `top`, and another `drop` metres lower beyond.
fn ledge(top: f32, drop: f32) -> Mesh {
    let mut m = Mesh::default();
    add_box(
        &mut m,
        [-3.0, -3.0, top - 1.0],
        [1.5, 3.0, top],
        Surface::Concrete,
    );
    add_box(
        &mut m,
        [1.5, -3.0, top - drop - 1.0],
        [8.0, 3.0, top - drop],
        Surface::Concrete,
    );
    m
}

/// From the origin along x to 4 m, on the ground the plan believes in.
fn plan(drop: f64) -> Vec<[f64; 4]> {
    (0..=40)
        .map(|i| {
            let x = 0.1 * i as f64;
            let z = if x < 1.5 { 0.0 } else { -drop };
            [x, 0.0, z, 0.0]
        })
        .collect()
}

fn drive(mesh: Mesh, drop: f64) -> Verdict {
    let p = SimulatorParams::default();
    let start = Stance::level(0.0, 0.0, p.base_height_m, 0.0);
    let mut sim = InternalSim::new(p).expect("sim");
    sim.begin_on(start, plan(drop), mesh);
    for _ in 0..1_000_000 {
        if let Some(v) = sim.step_without_clouds(50) {
            return v;
        }
    }
    panic!("no verdict");
}

#[test]
fn a_rover_that_falls_is_refused_and_one_down_a_step_passes() {
    let step = drive(ledge(0.0, 0.15), 0.15);
    assert_eq!(step.outcome, Outcome::Reached, "{step:?}");
    let off = drive(ledge(0.0, 1.0), 1.0);
    assert_eq!(off.outcome, Outcome::TippedOver, "{off:?}");
    // The ground a metre under where the rover was put down.
    let flat = drive(ledge(-1.0, 0.0), 0.0);
    assert_eq!(flat.outcome, Outcome::Fell, "{flat:?}");
    assert_eq!(flat.drive_s, 0.0, "{flat:?}");
}
