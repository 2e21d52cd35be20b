//! The way back: a plan down a step the rover can drive off but not
//! climb back up reaches its goal, and is refused when its way back is
//! asked for; down a step it can climb, it passes either way.

use speleo_hal::world::{shapes::add_box, Mesh, Surface};
use speleo_simulator::{InternalSim, Outcome, SimulatorParams, Stance, Verdict};

/// A floor at z = 0 up to x = 2, and `drop` lower beyond it.
fn step_down(drop: f32) -> Mesh {
    let mut m = Mesh::default();
    add_box(&mut m, [-3.0, -3.0, -1.0], [2.0, 3.0, 0.0], Surface::Rock);
    add_box(&mut m, [2.0, -3.0, -1.0], [12.0, 3.0, -drop], Surface::Rock);
    m
}

/// Straight along x from 0 to 5 m, on the floor's top.
fn plan(drop: f64) -> Vec<[f64; 4]> {
    (0..=50)
        .map(|i| {
            let x = 0.1 * i as f64;
            let z = if x < 2.0 { 0.0 } else { -drop };
            [x, 0.0, z, 0.0]
        })
        .collect()
}

/// The verdict, the prediction and the physics steps taken.
fn drive(drop: f32, way_back: bool) -> (Verdict, Vec<[f64; 3]>, u64) {
    let p = SimulatorParams {
        way_back_drop_m: 0.1,
        ..SimulatorParams::default()
    };
    let start = Stance::level(0.0, 0.0, p.base_height_m, 0.0);
    let mut sim = InternalSim::new(p).expect("sim");
    sim.begin_on(start, plan(drop as f64), step_down(drop));
    if way_back {
        sim.check_way_back();
    }
    for _ in 0..1_000_000 {
        if let Some(v) = sim.step_without_clouds(50) {
            return (v, sim.prediction().to_vec(), sim.counters.physics_steps);
        }
    }
    panic!("no verdict");
}

#[test]
fn a_step_down_the_rover_cannot_climb_back_is_refused_only_when_the_way_back_is_asked_for() {
    let (there, forward, _) = drive(0.3, false);
    assert_eq!(there.outcome, Outcome::Reached, "{there:?}");
    let (and_back, prediction, _) = drive(0.3, true);
    assert_eq!(and_back.outcome, Outcome::NoWayBack, "{and_back:?}");
    // The plan's own drive is told as it was: same time, same track.
    assert_eq!(and_back.drive_s, there.drive_s);
    assert_eq!(and_back.goal_error_m, there.goal_error_m);
    assert_eq!(prediction, forward);
}

#[test]
fn a_step_down_the_rover_can_climb_back_passes_with_its_way_back() {
    let (there, _, steps_there) = drive(0.15, false);
    let (v, _, steps) = drive(0.15, true);
    assert_eq!(v, there);
    // It was driven back: backward, at half speed, 5 m.
    assert!(steps > steps_there + 1000, "{steps} {steps_there}");
}

#[test]
fn on_level_ground_the_way_back_is_not_driven() {
    let (plain, a, steps_plain) = drive(0.0, false);
    let (asked, b, steps_asked) = drive(0.0, true);
    assert_eq!(plain, asked);
    assert_eq!(a, b);
    assert_eq!(steps_plain, steps_asked);
}
