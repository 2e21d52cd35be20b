//! The autonomous mission end to end: the rover explores the 30 m
//! `short-tube` on its own and comes home, every plan first driven in the
//! internal simulator. About 400 s of mission time: a
//! few minutes in a release build, far longer in the debug test build, so
//! it is ignored there and run with
//! `cargo test --release -p speleo-tests --test exploration -- --ignored`
//! (as `ci/test.sh` does), and so is the same tube with a small energy
//! budget, which sends the rover home early. Also, in a second: a rover
//! wrecked in a fall ends its mission, and the report says so.

use speleo_firmware::args::{Outputs, SimArgs};
use speleo_firmware::commands;
use std::path::PathBuf;

/// `speleo sim` in `world` (seed 1) for at most `duration_s`, with the
/// configuration `toml` (and a plot when asked): its report.
fn mission(world: &str, duration_s: f64, toml: &str, plot: Option<PathBuf>) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let config = dir.path().join("mission.toml");
    let report = dir.path().join("r.json");
    std::fs::write(&config, toml).unwrap_or_else(|e| panic!("{e}"));
    let r = commands::sim_mission(
        SimArgs {
            world: Some(world.into()),
            start: None,
            seed: Some(1),
            noise_seed: None,
            duration: Some(duration_s),
            config: Some(config),
            route: false,
            trajectory: None,
            faults: Vec::new(),
            dump_validations: None,
            out: Outputs {
                report: Some(report.clone()),
                ..Outputs::default()
            },
        },
        false,
    )
    .unwrap_or_else(|e| panic!("sim failed: {e}"));
    if let Some(path) = &plot {
        let title = format!("{world}, seed 1");
        speleo_tools::plot::write_plot(path, &speleo_tools::plot::of_mission(&r, title))
            .unwrap_or_else(|e| panic!("plot: {e}"));
    }
    let text = std::fs::read_to_string(&report).unwrap_or_else(|e| panic!("{e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
#[ignore = "a whole exploration: run in release (see the module documentation)"]
fn a_short_tube_is_explored_end_to_end_and_the_rover_comes_home() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let plot = dir.path().join("r.png");
    let r = mission(
        "short-tube",
        900.0,
        "[exploration]\nenabled = true\n",
        Some(plot.clone()),
    );
    let e = &r["exploration"];
    let f = |k: &str| e[k].as_f64().unwrap_or(f64::NAN);
    assert_eq!(e["state"], "finished", "{e}");
    assert_eq!(e["return_reason"], "explored", "{e}");
    assert!(f("coverage_fraction") >= 0.85, "{e}");
    assert!(f("home_error_m") <= 0.5, "{e}");
    assert_eq!(e["collisions"], 0, "{e}");
    assert_eq!(e["falls"], 0, "{e}");
    assert_eq!(e["wrecked"], false, "{e}");
    // It ended the mission itself, well before the 900 s allowed.
    assert!(
        r["sim_time_s"].as_f64().unwrap_or(f64::NAN) < 800.0,
        "{}",
        r["sim_time_s"]
    );
    assert_eq!(r["scheduler"]["allocations_after_init"], 0);
    assert!(std::fs::metadata(&plot)
        .map(|m| m.len() > 1000)
        .unwrap_or(false));
    // The energy drawn, every drive's torque measured once they run:
    // about 6 Wh of base draw over the mission and 4 Wh of driving.
    assert!(
        f("energy_used_wh") > 7.0 && f("energy_used_wh") < 14.0,
        "{e}"
    );
    assert!(f("energy_unmeasured_s") < 1.0, "{e}");
}

/// With a 6 Wh budget (the whole tube takes about 14 Wh) the rover turns
/// home while what is left is what the way home is expected to take,
/// and gets home within it.
#[test]
#[ignore = "a whole exploration: run in release (see the module documentation)"]
fn an_energy_budget_sends_the_rover_home_in_time() {
    let r = mission(
        "short-tube",
        900.0,
        "[exploration]\nenabled = true\nenergy_budget_wh = 6.0\n",
        None,
    );
    let e = &r["exploration"];
    let f = |k: &str| e[k].as_f64().unwrap_or(f64::NAN);
    assert_eq!(e["state"], "finished", "{e}");
    assert_eq!(e["return_reason"], "energy", "{e}");
    assert!(f("home_error_m") <= 0.5, "{e}");
    assert!(f("energy_used_wh") <= 6.0, "{e}");
    // It went some way first, and turned before the tube's far end, about
    // 18 m from the start (from the middle of the tube the scans see most
    // of it, so the share seen says little about how far it went).
    assert!(f("distance_m") > 10.0, "{e}");
    assert!(f("reach_m") < 15.0, "{e}");
}

/// A rover let go 3 m over the flat world's ground falls, is wrecked, and
/// the mission ends there, with the fall in the report.
#[test]
fn a_rover_wrecked_in_a_fall_ends_the_mission_and_the_report_says_so() {
    let r = mission(
        "flat",
        60.0,
        "[exploration]\nenabled = true\n[sim]\nstart = [0.0, 0.0, 3.0, 0.0]\n",
        None,
    );
    let e = &r["exploration"];
    assert_eq!(e["falls"], 1, "{e}");
    assert_eq!(e["wrecked"], true, "{e}");
    let h = e["worst_fall_m"].as_f64().unwrap_or(f64::NAN);
    assert!((h - 3.0).abs() < 0.2, "{e}");
    // Ended at the strike (0.8 s of free fall), not at the 60 s allowed.
    let t = r["sim_time_s"].as_f64().unwrap_or(f64::NAN);
    assert!(t < 2.0, "{t}");
}

/// A world read from a mesh file (the short tube written out as PLY) has
/// its reachable floor and a coverage figure, as the generated world has,
/// even when the rover has explored nothing yet.
#[test]
fn a_mesh_file_world_has_its_reachable_floor_and_a_coverage_figure() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let ply = dir.path().join("short-tube.ply");
    let world = speleo_twin::world::World::build("short-tube", 1).unwrap_or_else(|e| panic!("{e}"));
    let mut out = std::fs::File::create(&ply).unwrap_or_else(|e| panic!("{e}"));
    world
        .mesh
        .write_ply(&mut out)
        .unwrap_or_else(|e| panic!("{e}"));
    drop(out);
    let toml = "[exploration]\nenabled = true\n";
    let floor = |r: &serde_json::Value| {
        let e = &r["exploration"];
        let area = e["reachable_floor_m2"].as_f64();
        let coverage = e["coverage_fraction"].as_f64();
        assert!(coverage.is_some_and(|c| (0.0..=1.0).contains(&c)), "{e}");
        area.unwrap_or_else(|| panic!("no reachable floor: {e}"))
    };
    let generated = floor(&mission("short-tube", 1.0, toml, None));
    let scanned = floor(&mission(ply.to_str().unwrap_or_default(), 1.0, toml, None));
    assert!(generated > 50.0, "{generated}");
    assert!(
        (scanned - generated).abs() < 0.05 * generated,
        "{scanned} against {generated}"
    );
}
