//! Ctrl-C during a mission: the run ends at a frame boundary with its
//! recording finalised (summary and index) and its report written, and
//! the process exits 130.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Send `signal` (a `kill` name: INT, TERM) to process `pid`.
fn send(signal: &str, pid: u32) {
    let ok = Command::new("kill")
        .args([format!("-{signal}"), pid.to_string()])
        .status()
        .expect("kill runs")
        .success();
    assert!(ok, "kill -{signal} {pid}");
}

#[test]
fn ctrl_c_during_a_recorded_mission_finalises_the_recording_and_the_report() {
    let d = tempfile::tempdir().expect("tmp");
    let (rec, report) = (d.path().join("r.mcap"), d.path().join("r.json"));
    let child = Command::new(env!("CARGO_BIN_EXE_speleo"))
        .args([
            "sim",
            "--world",
            "short-tube",
            "--duration",
            "600",
            "--no-progress",
        ])
        .arg("--record")
        .arg(&rec)
        .arg("--report")
        .arg(&report)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("speleo runs");
    // Once the recording has its first chunk, the mission is under way.
    let started = Instant::now();
    while std::fs::metadata(&rec).map_or(0, |m| m.len()) < 1 << 20 {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no recording after 120 s"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    send("INT", child.id());
    let out = child.wait_with_output().expect("waits");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    // The report covers what was done, short of the 600 s asked for.
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let s = r["sim_time_s"].as_f64().expect("sim_time_s");
    assert!(s > 0.0 && s < 600.0, "{s}");
    // Finalised: a summary with statistics and a chunk index, so any MCAP
    // reader (not only ours) opens it.
    let bytes = std::fs::read(&rec).expect("recording");
    let summary = mcap::Summary::read(&bytes)
        .expect("readable")
        .expect("a summary section");
    assert!(!summary.chunk_indexes.is_empty());
    assert!(summary.stats.is_some_and(|st| st.message_count > 0));
}
