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
    std::fs::write(&cfg, "[record]\npool_messages = 16\n").expect("write config");
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
        assert_eq!(t["allocations"], 0, "{}", t["name"]);
        assert!(t["runs"].as_u64().unwrap_or(0) > 0, "{}", t["name"]);
    }
}
