//! No allocation after start-up in the executive and the periodic tasks,
//! measured with the accounting allocator over 12,000 frames with recording.

use speleo_scheduler::accounting::AccountingAllocator;
use speleo_tests::{read_json, sim, Scratch};

#[global_allocator]
static ALLOC: AccountingAllocator = AccountingAllocator;

#[test]
fn twelve_thousand_recorded_frames_allocate_nothing() {
    let s = Scratch::new();
    let report = s.path("a.json");
    sim(1, 120.0, Some(&s.path("a.mcap")), Some(&report));
    let r = read_json(&report);
    assert_eq!(r["frames"], 12_000);
    assert_eq!(r["scheduler"]["allocations_after_init"], 0);
    for t in r["scheduler"]["tasks"].as_array().expect("tasks") {
        assert_eq!(t["allocations"], 0, "{}", t["name"]);
        assert!(t["runs"].as_u64().unwrap_or(0) > 0, "{}", t["name"]);
    }
}
