//! The way back: a plan down a step the rover can drive off but not
//! climb back up reaches its goal, and is refused when its way back is
//! asked for; down a step it can climb, it passes either way.

mod common;

use common::{run_to_verdict, step_down, straight_plan};
use speleo_physics::Material;
use speleo_simulator::{InternalSim, Outcome, SimulatorParams, Stance, Verdict};

/// The verdict, the prediction and the physics steps taken.
fn drive(drop: f32, way_back: bool) -> (Verdict, Vec<[f64; 3]>, u64) {
    let p = SimulatorParams {
        way_back_drop_m: 0.1,
        ..SimulatorParams::default()
    };
    let start = Stance::level(0.0, 0.0, p.base_height_m, 0.0);
    let mut sim = InternalSim::new(p).expect("sim");
    // A floor at z = 0 up to x = 2, and `drop` lower beyond; 5 m along x.
    let ground = step_down(0.0, 2.0, drop, Material::Rock);
    sim.begin_on(start, straight_plan(5.0, 2.0, drop as f64), ground);
    if way_back {
        sim.check_way_back();
    }
    let v = run_to_verdict(&mut sim);
    (v, sim.prediction().to_vec(), sim.counters.physics_steps)
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
