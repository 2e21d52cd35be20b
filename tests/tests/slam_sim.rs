//! SLAM inside the executive on the simulated lava tube: keyframes are made
//! and optimised, the keyframes stay close to the ground truth, the run
//! (SLAM pose included in the recorded outputs) replays identically, and a
//! wrong loop closure injected into the same run leaves the map in place.

use std::process::ExitCode;

use speleo_tests::{read_json, read_tum, replay, sim_with_trajectory, Scratch};

const SEED: u64 = 1;
const SECONDS: f64 = 30.0;

#[test]
fn slam_tracks_the_tube_replays_and_shrugs_off_a_false_loop_closure() {
    let s = Scratch::new();
    let log = s.path("s.mcap");
    let report = s.path("s.json");
    let clean = s.path("clean.tum");
    sim_with_trajectory(SEED, SECONDS, None, Some(&log), Some(&report), Some(&clean));
    let r = read_json(&report);
    let slam = &r["slam"];
    let f = |k: &str| slam[k].as_f64().unwrap_or(f64::NAN);
    assert!(f("keyframes") >= 8.0, "{slam}");
    assert!(f("ate_mean_m") < 0.2, "{slam}");
    assert!(f("ate_max_m") < 0.35, "{slam}");
    assert_eq!(r["scheduler"]["allocations_after_init"], 0);
    // The out-and-back plan (hundreds of waypoints) is recorded too.
    assert_eq!(r["recorder"]["too_large"], 0, "{}", r["recorder"]);
    assert_eq!(replay(&log, None), ExitCode::SUCCESS);

    // The same run with a loop closure from keyframe 7 to keyframe 1 that
    // is 1.6 m and 5 deg wrong, as confident as a real registration.
    let config = s.path("false_loop.toml");
    std::fs::write(
        &config,
        "[sim]\nfalse_loop_closure = { older = 1, newer = 7, offset_m = [1.5, 0.5, 0.2], yaw_deg = 5.0 }\n",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let faulted_report = s.path("f.json");
    let faulted = s.path("faulted.tum");
    sim_with_trajectory(
        SEED,
        SECONDS,
        Some(&config),
        None,
        Some(&faulted_report),
        Some(&faulted),
    );
    let fr = read_json(&faulted_report);
    let fs = &fr["slam"];
    assert_eq!(fs["external_loop_closures"], 1, "{fs}");
    let g = |k: &str| fs[k].as_f64().unwrap_or(f64::NAN);
    // Keyframes up to the injection were taken at the same times in both
    // runs; the map must not move by more than the noise.
    let (a, b) = (read_tum(&clean), read_tum(&faulted));
    let truth = read_tum(&s.path("clean.truth.tum"));
    // The odometry beside them: a pose at every keyframe's time, from the
    // same start.
    let odom = read_tum(&s.path("clean.odom.tum"));
    assert_eq!(odom.len(), a.len(), "odometry rows");
    assert!(
        odom.iter().zip(&a).all(|(o, e)| o.0 == e.0),
        "odometry times"
    );
    let start = (0..3)
        .map(|k| (odom[0].1[k] - a[0].1[k]).abs())
        .fold(0.0, f64::max);
    assert!(
        start < 0.01,
        "odometry starts {start} m from SLAM's first keyframe"
    );
    let mut moved: f64 = 0.0;
    for ((ta, pa), (tb, pb)) in a.iter().zip(&b).take(8) {
        assert_eq!(ta, tb, "keyframe times before the injection");
        let d = (0..3).map(|k| (pa[k] - pb[k]).powi(2)).sum::<f64>().sqrt();
        moved = moved.max(d);
    }
    let noise = a
        .iter()
        .zip(&truth)
        .map(|((_, p), (_, t))| (0..3).map(|k| (p[k] - t[k]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    println!("false loop moved the first 8 keyframes by {moved:.4} m; clean ATE max {noise:.4} m");
    assert!(moved <= noise.max(0.03), "moved {moved} m, noise {noise} m");
    assert!(g("ate_max_m") <= f("ate_max_m") + 0.05, "{fs} vs {slam}");
}
