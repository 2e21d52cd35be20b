//! The `speleo` binary as a user meets it: separate processes, exit codes,
//! messages, and a recording whose process was killed.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn speleo(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_speleo"))
        .args(args)
        .arg("--no-progress")
        .output()
        .expect("speleo runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn hash_of(report: &Path) -> String {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).expect("report")).expect("json");
    v["output_hash"].as_str().expect("hash").to_string()
}

#[test]
fn two_processes_give_the_same_output_hash() {
    let d = tempfile::tempdir().expect("tmp");
    let (a, b) = (d.path().join("a.json"), d.path().join("b.json"));
    for r in [&a, &b] {
        let out = speleo(&[
            "sim",
            "--duration",
            "5",
            "--seed",
            "4",
            "--report",
            r.to_str().expect("utf8"),
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    assert_eq!(hash_of(&a), hash_of(&b));
}

/// Run `speleo sim` with `toml` as its configuration file `name`; it must
/// refuse with status 2. Returns what it printed.
fn refused(name: &str, toml: &str) -> String {
    let d = tempfile::tempdir().expect("tmp");
    let cfg = d.path().join(name);
    std::fs::write(&cfg, toml).expect("write");
    let out = speleo(&[
        "sim",
        "--duration",
        "1",
        "--config",
        cfg.to_str().expect("utf8"),
    ]);
    assert_eq!(out.status.code(), Some(2));
    text(&out.stderr)
}

#[test]
fn an_unknown_key_is_refused_by_name() {
    let e = refused(
        "bad.toml",
        "[executive]\nminor_frame_us = 10000\nminor_frame_ms = 10\n",
    );
    assert!(e.contains("minor_frame_ms"), "{e}");
    assert!(e.contains("bad.toml"), "{e}");
}

#[test]
fn a_budget_that_cannot_fit_is_refused_with_frame_and_tasks() {
    let e = refused("tight.toml", "[tasks.recorder]\nbudget_us = 8000\n");
    assert!(e.contains("unschedulable"), "{e}");
    assert!(e.contains("minor frame 0"), "{e}");
    assert!(e.contains("recorder 8000 us"), "{e}");
}

#[test]
fn a_recording_whose_process_was_killed_replays_up_to_its_last_chunk() {
    let d = tempfile::tempdir().expect("tmp");
    let cfg = d.path().join("small-chunks.toml");
    std::fs::write(&cfg, "[record]\nchunk_size_kib = 32\n").expect("write");
    let log = d.path().join("killed.mcap");
    let mut child = Command::new(env!("CARGO_BIN_EXE_speleo"))
        .args(["sim", "--no-progress", "--duration", "100000", "--config"])
        .arg(&cfg)
        .arg("--record")
        .arg(&log)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn");
    let start = Instant::now();
    while std::fs::metadata(&log).map_or(0, |m| m.len()) < 400_000 {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "recording did not grow"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().expect("SIGKILL");
    let status = child.wait().expect("wait");
    assert!(!status.success());

    let report = d.path().join("r.json");
    let out = speleo(&[
        "replay",
        log.to_str().expect("utf8"),
        "--report",
        report.to_str().expect("utf8"),
    ]);
    assert!(
        out.status.success(),
        "{}{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    assert_eq!(text(&out.stdout).trim(), "identical");
    assert!(
        text(&out.stderr).contains("ends early"),
        "{}",
        text(&out.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    assert_eq!(v["replay"]["recording_truncated"], true);
    assert!(v["frames"].as_u64().unwrap_or(0) > 100, "{v}");
}

#[test]
fn files_that_are_not_recordings_are_refused_clearly() {
    let d = tempfile::tempdir().expect("tmp");
    let junk = d.path().join("junk.mcap");
    std::fs::write(&junk, b"this is not an mcap file").expect("write");
    let out = speleo(&["replay", junk.to_str().expect("utf8")]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("not an MCAP recording"),
        "{}",
        text(&out.stderr)
    );
    let out = speleo(&[
        "replay",
        d.path().join("absent.mcap").to_str().expect("utf8"),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("cannot read"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn a_damaged_chunk_is_refused_not_replayed() {
    let d = tempfile::tempdir().expect("tmp");
    let log = d.path().join("a.mcap");
    let out = speleo(&[
        "sim",
        "--duration",
        "3",
        "--record",
        log.to_str().expect("utf8"),
    ]);
    assert!(out.status.success());
    let mut bytes = std::fs::read(&log).expect("read");
    // The middle of the first chunk's compressed body.
    let scan = speleo_firmware::record::read::scan_records(&bytes);
    let &(_, at, len) = scan.records.iter().find(|r| r.0 == 0x06).expect("a chunk");
    bytes[at + len / 2] ^= 0xFF;
    std::fs::write(&log, &bytes).expect("write");
    let out = speleo(&["replay", log.to_str().expect("utf8")]);
    assert_eq!(out.status.code(), Some(2));
    let e = text(&out.stderr);
    assert!(e.contains("damaged"), "{e}");
}

#[test]
fn help_explains_every_option() {
    let out = speleo(&["sim", "--help"]);
    let h = text(&out.stdout);
    for opt in [
        "--world",
        "--seed",
        "--duration",
        "--record",
        "--report",
        "--config",
    ] {
        assert!(h.contains(opt), "{opt} missing from:\n{h}");
    }
    let h = text(&speleo(&["replay", "--help"]).stdout);
    assert!(h.contains("identical"), "{h}");
}
