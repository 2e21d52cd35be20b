//! No allocation after start-up in the executive and the periodic tasks,
//! measured with the accounting allocator over 12,000 frames with recording.
//! The recorder gets only 16 message buffers, so the executive keeps waiting
//! for the writer thread: the waiting path is exercised too.

use speleo_scheduler::accounting::AccountingAllocator;
use speleo_tests::{read_json, sim_with_config, Scratch};

#[global_allocator]
static ALLOC: AccountingAllocator = AccountingAllocator;

#[test]
fn twelve_thousand_recorded_frames_allocate_nothing() {
    let s = Scratch::new();
    let report = s.path("a.json");
    let cfg = s.path("small-pool.toml");
    // Without the LiDAR twin, whose 2 MB/s of packets would make this a
    // large file; the LiDAR path is measured below.
    std::fs::write(&cfg, "[record]\npool_messages = 16\n[sim]\nlidar = false\n")
        .expect("write config");
    sim_with_config(1, 120.0, Some(&cfg), Some(&s.path("a.mcap")), Some(&report));
    let r = read_json(&report);
    assert_eq!(r["frames"], 12_000);
    assert_eq!(r["scheduler"]["allocations_after_init"], 0);
    assert_eq!(r["recorder"]["dropped_no_buffer"], 0);
    // Nothing lost on the way to the disk.
    let bytes = std::fs::read(s.path("a.mcap")).expect("recording");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("present");
    let in_file = summary.stats.expect("statistics").message_count;
    assert_eq!(r["recorder"]["written"].as_u64(), Some(in_file));
    for t in r["scheduler"]["tasks"].as_array().expect("tasks") {
        // SLAM's solver analysis runs within a memory budget instead.
        if t["name"] != "slam" {
            assert_eq!(t["allocations"], 0, "{}", t["name"]);
        }
        assert!(t["runs"].as_u64().unwrap_or(0) > 0, "{}", t["name"]);
    }
}

#[test]
fn a_recorded_lidar_mission_allocates_nothing() {
    let s = Scratch::new();
    let report = s.path("a.json");
    let cfg = s.path("every-cloud.toml");
    // Every revolution decoded, recorded and hashed.
    std::fs::write(&cfg, "[record]\ncloud_every = 1\n").expect("write config");
    sim_with_config(2, 15.0, Some(&cfg), Some(&s.path("a.mcap")), Some(&report));
    let r = read_json(&report);
    assert_eq!(r["scheduler"]["allocations_after_init"], 0);
    assert_eq!(r["recorder"]["dropped_no_buffer"], 0);
    assert_eq!(r["recorder"]["too_large"], 0);
    let lidar = r["scheduler"]["tasks"]
        .as_array()
        .expect("tasks")
        .iter()
        .find(|t| t["name"] == "lidar_driver")
        .expect("lidar_driver")
        .clone();
    assert_eq!(lidar["allocations"], 0);
    let bytes = std::fs::read(s.path("a.mcap")).expect("recording");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("present");
    let stats = summary.stats.expect("statistics");
    let count = |topic: &str| {
        summary
            .channels
            .values()
            .find(|c| c.topic == topic)
            .and_then(|c| stats.channel_message_counts.get(&c.id).copied())
            .unwrap_or(0)
    };
    // 10 Hz for 15 s (the first revolution starts mid-turn).
    assert!(count("/lidar/points") >= 148, "{}", count("/lidar/points"));
    // About 1,808 packets a second.
    let packets = count("/raw/lidar");
    assert!((15 * 1800..15 * 1815).contains(&packets), "{packets}");
}
