//! A rover that the safety monitor stopped past its tilt limit, on a
//! slope: the monitor lets it move while the tilt does not grow, so the
//! internal simulation judges the way down alike, where it used to call
//! every plan from there a tip-over at once (the lava tube's rover,
//! stopped at 30.1 degrees on the muddy entrance, was stranded so).

mod common;

use common::run_to_verdict;
use speleo_physics::{Material, Mesh};
use speleo_simulator::{InternalSim, Outcome, SimulatorParams, Stance, Verdict};
use speleo_twin::world::shapes::add_hexahedron;

/// A 31 degree slope rising along +x from x = 0 to 4 m, on a floor.
const SLOPE_DEG: f64 = 31.0;

fn slope() -> Mesh {
    let top = (4.0 * SLOPE_DEG.to_radians().tan()) as f32;
    let mut m = Mesh::default();
    // The floor, then the wedge on it.
    add_hexahedron(
        &mut m,
        [
            [-6.0, -3.0, -1.0],
            [8.0, -3.0, -1.0],
            [8.0, 3.0, -1.0],
            [-6.0, 3.0, -1.0],
            [-6.0, -3.0, 0.0],
            [8.0, -3.0, 0.0],
            [8.0, 3.0, 0.0],
            [-6.0, 3.0, 0.0],
        ],
        Material::Concrete,
    );
    add_hexahedron(
        &mut m,
        [
            [0.0, -3.0, 0.0],
            [4.0, -3.0, 0.0],
            [4.0, 3.0, 0.0],
            [0.0, 3.0, 0.0],
            [0.0, -3.0, 0.0],
            [4.0, -3.0, top],
            [4.0, 3.0, top],
            [0.0, 3.0, 0.0],
        ],
        Material::Concrete,
    );
    m
}

/// From x = 2.5 on the slope, facing down it, to the floor at x = -2.
fn drive_down(tip_over_deg: f64) -> Verdict {
    let p = SimulatorParams {
        tip_over_deg,
        start_tilted: true,
        ..SimulatorParams::default()
    };
    let a = SLOPE_DEG.to_radians();
    let x0 = 2.5;
    let ground = |x: f64| if x > 0.0 { x * a.tan() } else { 0.0 };
    let start = Stance {
        position: [x0, 0.0, ground(x0) + p.base_height_m / a.cos()],
        yaw: std::f64::consts::PI,
        pitch: a,
        roll: 0.0,
    };
    let plan: Vec<[f64; 4]> = (0..=45)
        .map(|i| {
            let x = x0 - 0.1 * i as f64;
            [x, 0.0, ground(x), std::f64::consts::PI]
        })
        .collect();
    let mut sim = InternalSim::new(p).expect("sim");
    sim.begin_on(start, plan, slope());
    run_to_verdict(&mut sim)
}

#[test]
fn a_rover_stopped_past_the_tilt_limit_may_drive_down_the_slope() {
    // The safety monitor's limit (the firmware caps tip_over_deg by it):
    // stopped at 31 degrees, the legs rock the rover by up to 3 degrees on
    // the way down, within the 2 degrees of growth over the settled tilt.
    let down = drive_down(30.0);
    assert_eq!(down.outcome, Outcome::Reached, "{down:?}");
    // Within the limit from the start, the same way down passes too.
    let within = drive_down(35.0);
    assert_eq!(within.outcome, Outcome::Reached, "{within:?}");
}
