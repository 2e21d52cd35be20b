//! The simulated HDL-32E in a mission: its packets go through the real
//! driver, revolutions are recorded as point clouds, and the run replays
//! identically.

use std::process::ExitCode;

use speleo_tests::{read_json, replay, sim_with_config, Scratch};

#[test]
fn simulated_lidar_packets_become_recorded_clouds_and_replay_identically() {
    let s = Scratch::new();
    let cfg = s.path("lidar.toml");
    std::fs::write(&cfg, "[sim]\nlidar = true\n").expect("config");
    let log = s.path("l.mcap");
    sim_with_config(5, 1.5, Some(&cfg), Some(&log), Some(&s.path("a.json")));
    let bytes = std::fs::read(&log).expect("recording");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("present");
    let count = |topic: &str| {
        summary
            .channels
            .values()
            .find(|c| c.topic == topic)
            .and_then(|c| {
                summary
                    .stats
                    .as_ref()
                    .and_then(|st| st.channel_message_counts.get(&c.id).copied())
            })
            .unwrap_or(0)
    };
    // ~1,808 packets a second; a revolution every 0.1 s.
    assert!(count("/raw/lidar") > 2_500, "{}", count("/raw/lidar"));
    assert!(count("/lidar/points") >= 13, "{}", count("/lidar/points"));
    assert_eq!(replay(&log, Some(&s.path("r.json"))), ExitCode::SUCCESS);
    let r = read_json(&s.path("r.json"));
    assert_eq!(r["replay"]["identical"], true);
    assert_eq!(r["scheduler"]["allocations_after_init"], 0);
}
