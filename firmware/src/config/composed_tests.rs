//! The sections that hold components' parameters (`[slam]`, `[planner]`,
//! `[simulator]`) read and write the keys they always had, refuse unknown
//! keys and out-of-range values by name, and default to the components'
//! defaults.

use super::*;

/// A section's keys as the default configuration writes them.
fn keys_of(section: &str) -> Vec<String> {
    let all: toml::Table = toml::from_str(&Config::default().to_toml()).expect("parses");
    let mut keys: Vec<String> = all[section]
        .as_table()
        .expect("a table")
        .keys()
        .cloned()
        .collect();
    keys.sort();
    keys
}

fn sorted(keys: &[&str]) -> Vec<String> {
    let mut k: Vec<String> = keys.iter().map(|s| s.to_string()).collect();
    k.sort();
    k
}

#[test]
fn the_composed_sections_write_the_keys_they_always_had() {
    let slam = [
        "enabled",
        "keyframe_capacity",
        "active_keyframes",
        "submap_keyframes",
        "keyframe_distance_m",
        "keyframe_angle_deg",
        "voxel_m",
        "max_range_m",
        "max_scan_points",
        "neighbors",
        "loop_radius_m",
        "loop_min_gap",
        "refine_distance_m",
        "refine_mutual",
        "min_surface_share",
        "loop_verify_distance_m",
        "loop_max_fitness_m",
        "loop_min_inlier_fraction",
        "odom_sigma_m_per_m",
        "odom_sigma_rad_per_s",
        "odom_sigma_vertical_m_per_m",
        "inclination_sigma_deg",
        "estimate_bias",
        "bias_prior_deg",
        "points_per_step",
        "factors_per_step",
    ];
    assert_eq!(keys_of("slam"), sorted(&slam));
    let planner = [
        "enabled",
        "window_m",
        "window_max_m",
        "max_nodes",
        "goal_ahead_m",
        "replan_every_s",
        "max_expansions",
        "initial_eps",
        "eps_step",
        "max_slope_deg",
        "max_step_m",
        "ground_clearance_m",
        "forward_speed_mps",
        "backward_speed_mps",
        "turn_speed_rad_s",
        "body_length_m",
        "body_width_m",
        "clearance_weight",
        "bump_weight",
        "max_bump_m",
        "edge_weight",
        "edge_reach_m",
        "body_drop_cells",
        "drop_clearance_m",
        "deep_drop_m",
        "mprim",
        "step_units",
    ];
    assert_eq!(keys_of("planner"), sorted(&planner));
    // `dump_dir` is written when set.
    let simulator = [
        "enabled",
        "voxel_m",
        "max_blocks",
        "margin_m",
        "dt_s",
        "goal_tolerance_m",
        "tip_over_deg",
        "stuck_after_s",
        "newest_keyframes",
        "worker_units",
        "start_tilted",
        "start_tilted_over_deg",
        "way_back_drop_m",
        "overhang_depth_m",
        "pessimistic_friction",
        "pessimistic_tilt_margin_deg",
        "pessimistic_climb_m",
        "low_grip_reflectance",
        "low_grip_max_tilt_deg",
    ];
    assert_eq!(keys_of("simulator"), sorted(&simulator));
}

#[test]
fn the_composed_sections_default_to_the_components_defaults() {
    let c = Config::default();
    assert_eq!(
        c.slam.params,
        speleo_slam::graph_slam::SlamParams::default()
    );
    assert_eq!(c.planner.nav, speleo_navigator::NavigatorParams::default());
    assert_eq!(
        c.simulator.params,
        speleo_simulator::SimulatorParams::default()
    );
    assert_eq!(Config::from_toml("").expect("empty"), c);
    // A key of one component leaves the others' navigator defaults (2^16
    // nodes, the body with its margin, the bump cost) as they were.
    let p = Config::from_toml("[planner]\nwindow_m = 40.0\nclearance_weight = 1.5\n")
        .expect("read")
        .planner;
    assert_eq!(p.nav.window_m, 40.0);
    assert_eq!(p.nav.surface.clearance_weight, 1.5);
    let n = speleo_navigator::NavigatorParams::default();
    assert_eq!(p.nav.trav, n.trav);
    assert_eq!(p.nav.surface.body_length_m, n.surface.body_length_m);
    assert_eq!(p.nav.surface.bump_weight, n.surface.bump_weight);
    let c = Config::from_toml(
        "[slam]\nenabled = false\nvoxel_m = 0.3\n[simulator]\nenabled = false\ndt_s = 0.005\n\
         worker_units = 0\ndump_dir = \"cases\"\n[planner]\nmax_nodes = 1000\nmprim = \"x.mprim\"\n\
         [planner.step_units]\nsearch = 30\n",
    )
    .expect("read");
    assert!(!c.slam.enabled && !c.simulator.enabled);
    assert_eq!(c.slam.params.voxel_m, 0.3);
    assert_eq!(c.simulator.params.dt_s, 0.005);
    assert_eq!(c.simulator.worker_units, 0);
    assert_eq!(c.simulator.dump_dir, Some("cases".into()));
    assert_eq!(c.planner.nav.trav.max_nodes, 1000);
    assert_eq!(c.planner.mprim, "x.mprim");
    assert_eq!(c.planner.step_units.search, 30);
    assert_eq!(Config::from_toml(&c.to_toml()).expect("round trip"), c);
}

#[test]
fn the_composed_sections_refuse_unknown_keys_by_name() {
    for (text, key) in [
        ("[slam]\nenabled = true\ncolour = 2\n", "colour"),
        ("[slam]\nneighbor_radius_m = 8.0\n", "neighbor_radius_m"),
        ("[planner]\nmax_nodez = 16\n", "max_nodez"),
        ("[planner]\nrobot_height_m = 0.7\n", "robot_height_m"),
        ("[planner.step_units]\nsearh = 3\n", "searh"),
        ("[simulator]\ntile_m = 0.25\n", "tile_m"),
    ] {
        let e = Config::from_toml(text).expect_err(text).to_string();
        assert!(e.contains(&format!("`{key}`")), "{text}: {e}");
    }
}

#[test]
fn the_composed_sections_refuse_values_out_of_range_and_wrong_types_by_key() {
    for (text, key) in [
        ("[slam]\nneighbors = 9\n", "slam.neighbors"),
        ("[slam]\nvoxel_m = 0.0\n", "slam.voxel_m"),
        ("[slam]\nneighbors = \"three\"\n", "slam.neighbors"),
        ("[slam]\nenabled = 1\n", "slam.enabled"),
        ("[planner]\nwindow_m = 1.0\n", "planner.window_m"),
        ("[planner]\nmax_nodes = 8\n", "planner.max_nodes"),
        ("[planner]\nmax_step_m = 0.5\n", "planner.max_step_m"),
        (
            "[planner]\nforward_speed_mps = 20.0\n",
            "planner.forward_speed_mps",
        ),
        ("[planner]\nmax_bump_m = 0.2\n", "planner.max_bump_m"),
        ("[planner]\nwindow_max_m = 501.0\n", "planner.window_max_m"),
        (
            "[planner.step_units]\nsearch = 0\n",
            "planner.step_units.search",
        ),
        ("[simulator]\ndt_s = 0.5\n", "simulator.dt_s"),
        (
            "[simulator]\nworker_units = 5000\n",
            "simulator.worker_units",
        ),
        ("[simulator]\nmax_blocks = -1\n", "simulator.max_blocks"),
    ] {
        let e = Config::from_toml(text).expect_err(text).to_string();
        assert!(e.contains(key), "{text}: {e}");
    }
}
