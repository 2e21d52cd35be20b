//! Bounded memory: once SLAM's keyframe capacity is full, a mission twice
//! as long does not raise the heap's high-water mark beyond the variation
//! of the solver's own transient work, and no task's run asks for more
//! than its memory budget. Alone in its test binary: the high-water mark
//! is the whole process's.

use speleo_scheduler::accounting::AccountingAllocator;
use speleo_tests::{read_json, sim_with_config, Scratch};

#[global_allocator]
static ALLOC: AccountingAllocator = AccountingAllocator;

/// How much the solver's transient allocations vary from one keyframe to
/// the next (measured: 4 to 52 kB on the flat world and the lava tube).
const TRANSIENT_SLACK: u64 = 128 * 1024;

#[test]
fn the_heap_stays_flat_over_a_mission_twice_as_long_as_filling_slam() {
    let s = Scratch::new();
    let report = s.path("a.json");
    let cfg = s.path("small-slam.toml");
    // Four keyframes fill SLAM within the first 20 s.
    std::fs::write(
        &cfg,
        "[slam]\nkeyframe_capacity = 4\n[sim]\nworld = \"flat\"\n",
    )
    .expect("write config");
    sim_with_config(1, 40.0, Some(&cfg), None, Some(&report));
    let r = read_json(&report);
    assert_eq!(r["slam"]["keyframes"], 4, "SLAM is full");
    let m = &r["memory"];
    let num = |k: &str| m[k].as_u64().unwrap_or_else(|| panic!("{k}: {m}"));
    let (half, peak) = (num("heap_peak_first_half_bytes"), num("heap_peak_bytes"));
    assert!(half > 1 << 20, "the accounting allocator counts: {m}");
    assert!(
        peak - half <= TRANSIENT_SLACK,
        "the second half raised the high-water mark by {} bytes",
        peak - half
    );
    assert!(num("heap_live_end_bytes") <= half, "{m}");
    for t in r["scheduler"]["tasks"].as_array().expect("tasks") {
        if let Some(kib) = t["memory_budget_kib"].as_u64() {
            let used = t["alloc_bytes_max_run"].as_u64().expect("bytes");
            assert!(used <= kib * 1024, "{}: {used} bytes in a run", t["name"]);
        } else {
            assert_eq!(t["allocations"], 0, "{}", t["name"]);
        }
    }
}
