//! SLAM inside the executive on the simulated lava tube: keyframes are made
//! and optimised, the keyframes stay close to the ground truth, and the run
//! (SLAM pose included in the recorded outputs) replays identically.

use std::process::ExitCode;

use speleo_tests::{read_json, replay, sim_with_config, Scratch};

#[test]
fn slam_tracks_the_tube_estimates_the_bias_and_replays() {
    let s = Scratch::new();
    let log = s.path("s.mcap");
    let report = s.path("s.json");
    sim_with_config(1, 30.0, None, Some(&log), Some(&report));
    let r = read_json(&report);
    let slam = &r["slam"];
    let f = |k: &str| slam[k].as_f64().unwrap_or(f64::NAN);
    assert!(f("keyframes") >= 8.0, "{slam}");
    assert!(f("ate_mean_m") < 0.2, "{slam}");
    assert!(f("ate_max_m") < 0.35, "{slam}");
    assert_eq!(r["scheduler"]["allocations_after_init"], 0);
    assert_eq!(replay(&log, None), ExitCode::SUCCESS);
}
