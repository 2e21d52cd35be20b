//! The hardware-in-the-loop bench end to end: `speleo hil` runs the twin
//! and the flight binary (`speleo run`) as two processes in real time on
//! the real wires (UDP, two pseudo-terminals, slcan) on the short tube,
//! with the twin's LiDAR unplugged for 5 s on the way. Real time needs the
//! release build: `cargo test --release -p speleo-cli --test hil -- --ignored`
//! (CI runs it so).

use std::path::Path;
use std::process::Command;

use serde_json::Value;

const SPELEO: &str = env!("CARGO_BIN_EXE_speleo");

/// Bench seconds, and the LiDAR's unplugging (twin time).
const DURATION_S: f64 = 100.0;
const UNPLUG_AT_S: f64 = 55.0;
const UNPLUG_FOR_S: f64 = 5.0;

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

fn bench(out: &Path) -> Value {
    let report = out.join("bench.json");
    let st = Command::new(SPELEO)
        .args([
            "--no-progress",
            "hil",
            "--world",
            "short-tube",
            "--duration",
        ])
        .arg(DURATION_S.to_string())
        .arg("--unplug-lidar")
        .arg(format!("{UNPLUG_AT_S}:{UNPLUG_FOR_S}"))
        .arg("--out")
        .arg(out)
        .arg("--report")
        .arg(&report)
        .status()
        .expect("speleo hil runs");
    assert!(st.success(), "speleo hil: {st}");
    serde_json::from_str(&std::fs::read_to_string(&report).expect("bench.json")).expect("JSON")
}

#[test]
#[ignore = "two processes in real time for 100 s: run in release (CI does)"]
fn the_flight_binary_drives_the_twin_over_the_wire_and_replays_identically() {
    let dir = tempfile::tempdir().expect("tempdir");
    let b = bench(dir.path());
    let (flight, twin, verdict) = (&b["flight"], &b["twin"], &b["bench"]);
    assert_eq!(
        (b["flight_exit"].as_i64(), b["twin_exit"].as_i64()),
        (Some(0), Some(0))
    );

    // It drove its plans: the twin's truth moved, and ended where the
    // flight binary believed it was.
    let driven = f(&verdict["truth_distance_m"]);
    assert!(driven > 2.0, "the rover truly drove {driven:.2} m");
    let error = f(&verdict["pose"]["position_error_m"]);
    assert!(
        error < 1.0,
        "ended {error:.2} m from where it believed it was"
    );
    // And all the way: each SLAM pose against the truth at its time (the
    // two recordings share the machine's clock); a simulated mission's
    // SLAM error is a few centimetres.
    let track = &verdict["track"];
    assert!(
        track["poses"].as_u64() > Some(1000) && f(&track["mean_m"]) < 0.25,
        "the SLAM track against the truth: {track}"
    );
    // The LiDAR's position packets came over their own port.
    assert!(
        flight["counters"]["lidar_position_packets"].as_u64() > Some(1000),
        "position packets: {}",
        flight["counters"]
    );

    // Every wire carried traffic both ways.
    let links = &twin["links"];
    for key in [
        "lidar_packets_sent",
        "imu_bytes_sent",
        "imu_bytes_received",
        "can_frames_to_host",
        "can_frames_from_host",
    ] {
        assert!(
            links[key].as_u64() > Some(0),
            "twin links: {key} = {}",
            links[key]
        );
    }
    // The flight binary closes the adapter before setting it up; a closed
    // adapter refuses that, and nothing else is refused.
    assert_eq!(links["can_lines_refused"].as_u64(), Some(1));
    assert_eq!(
        flight["counters"]["can_transport_dropped"].as_u64(),
        Some(0)
    );

    // Timing was measured and the executive kept its frames.
    let rt = &flight["realtime"];
    for key in [
        "lidar_to_wheel_command",
        "imu_to_odometry",
        "frame_start_lateness",
    ] {
        assert!(rt[key]["count"].as_u64() > Some(0), "{key}: {}", rt[key]);
    }
    let frames = flight["frames"].as_u64().unwrap_or(0);
    let slips = flight["scheduler"]["slips"].as_u64().unwrap_or(u64::MAX);
    assert!(slips * 100 <= frames, "{slips} slips in {frames} frames");

    // The unplugged LiDAR: the health task reported it, the safe schedule
    // stopped the wheels, and the rover went on once it was back.
    let episodes = flight["faults"]["episodes"].as_array().expect("episodes");
    let silent: Vec<&Value> = episodes
        .iter()
        .filter(|e| e["what"] == "lidar_silent")
        .collect();
    assert_eq!(silent.len(), 1, "lidar_silent episodes: {episodes:?}");
    let (from, until) = (f(&silent[0]["from_s"]), f(&silent[0]["until_s"]));
    assert!(
        (until - from - UNPLUG_FOR_S).abs() < 1.5,
        "lidar silent from {from:.2} to {until:.2} s"
    );
    // The safe schedule held the wheels through the silence (it may have
    // begun earlier, for another finding) and was left after it.
    let held = episodes
        .iter()
        .any(|e| e["what"] == "safe_mode" && f(&e["from_s"]) <= from && f(&e["until_s"]) >= until);
    assert!(
        held,
        "no safe stop through the LiDAR's silence: {episodes:?}"
    );

    // Both recordings were finalised, and the flight's replays identically.
    for name in ["flight.mcap", "twin.mcap"] {
        let bytes = std::fs::read(dir.path().join(name)).expect(name);
        let summary = mcap::Summary::read(&bytes).expect("an MCAP summary");
        assert!(summary.is_some(), "{name} has no summary");
    }
    let replay = Command::new(SPELEO)
        .args(["--no-progress", "replay"])
        .arg(dir.path().join("flight.mcap"))
        .output()
        .expect("speleo replay runs");
    let said = String::from_utf8_lossy(&replay.stdout);
    assert!(
        replay.status.success() && said.contains("identical"),
        "replay: {said}{}",
        String::from_utf8_lossy(&replay.stderr)
    );
}
