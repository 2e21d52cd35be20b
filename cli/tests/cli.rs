//! The `speleo` binary as a user meets it: separate processes, exit codes,
//! messages, and a recording whose process was killed.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::{speleo, text};

/// (output hash, input hash) of a report.
fn hashes_of(report: &Path) -> (String, String) {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).expect("report")).expect("json");
    let h = |k: &str| v[k].as_str().expect("hash").to_string();
    (h("output_hash"), h("input_hash"))
}

/// Run a 2 s simulation in its own process and return its hashes.
fn sim_hashes(dir: &Path, world: &str, seed: &str) -> (String, String) {
    sim_hashes_with(dir, world, seed, &[])
}

/// As [`sim_hashes`], with `extra` arguments.
fn sim_hashes_with(dir: &Path, world: &str, seed: &str, extra: &[&str]) -> (String, String) {
    let r = dir.join("r.json");
    let mut args = vec![
        "sim",
        "--world",
        world,
        "--duration",
        "2",
        "--seed",
        seed,
        "--report",
        r.to_str().expect("utf8"),
    ];
    args.extend_from_slice(extra);
    let out = speleo(&args);
    assert!(out.status.success(), "{world}: {}", text(&out.stderr));
    hashes_of(&r)
}

#[test]
fn every_world_gives_the_same_byte_streams_in_two_processes() {
    let d = tempfile::tempdir().expect("tmp");
    // A mesh-file world: the lava tube of seed 9 written out as PLY.
    let ply = d.path().join("tube9.ply");
    let out = speleo(&[
        "world",
        "export",
        "lava-tube",
        ply.to_str().expect("utf8"),
        "--seed",
        "9",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    for world in ["lava-tube", "garage", ply.to_str().expect("utf8")] {
        let a = sim_hashes(d.path(), world, "4");
        let b = sim_hashes(d.path(), world, "4");
        // Inputs: the LiDAR, IMU and CAN bytes; outputs: everything decoded.
        assert_eq!(a, b, "{world}");
    }
    // Another seed is another cave (and other sensor noise).
    let a = sim_hashes(d.path(), "lava-tube", "4");
    let c = sim_hashes(d.path(), "lava-tube", "5");
    assert_ne!(a.1, c.1);
}

#[test]
fn a_noise_seed_changes_the_sensors_noise_and_not_the_world() {
    let d = tempfile::tempdir().expect("tmp");
    let plain = sim_hashes(d.path(), "lava-tube", "4");
    // By default the noise follows the seed.
    let same = sim_hashes_with(d.path(), "lava-tube", "4", &["--noise-seed", "4"]);
    assert_eq!(plain, same);
    let other_noise = sim_hashes_with(d.path(), "lava-tube", "4", &["--noise-seed", "7"]);
    assert_ne!(plain.1, other_noise.1);
    // The same noise in another cave: the world still follows the seed.
    let other_cave = sim_hashes_with(d.path(), "lava-tube", "7", &["--noise-seed", "7"]);
    assert_ne!(other_noise.1, other_cave.1);
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

/// Record a simulated mission with small chunks and SIGKILL it once the
/// file has grown past `kill_at` bytes; the recording's path.
fn killed_recording(dir: &Path, name: &str, kill_at: u64) -> std::path::PathBuf {
    let cfg = dir.join("small-chunks.toml");
    std::fs::write(&cfg, "[record]\nchunk_size_kib = 32\n").expect("write");
    let log = dir.join(name);
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
    while std::fs::metadata(&log).map_or(0, |m| m.len()) < kill_at {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "recording did not grow"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().expect("SIGKILL");
    let status = child.wait().expect("wait");
    assert!(!status.success());
    log
}

#[test]
fn a_recording_whose_process_was_killed_replays_up_to_its_last_chunk() {
    let d = tempfile::tempdir().expect("tmp");
    // Past the first second of LiDAR data (about 3 MB a simulated second).
    let log = killed_recording(d.path(), "killed.mcap", 5_000_000);
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
fn a_recording_killed_at_random_moments_replays_what_it_holds_or_says_why_not() {
    // Kill points from a fixed seed, from before the first chunk is out
    // to a few chunks in; each kill lands wherever the writer happens to
    // be (a chunk half written, the summary never started).
    let d = tempfile::tempdir().expect("tmp");
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    for k in 0..4 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        // The first as soon as the file exists.
        let kill_at = if k == 0 { 1 } else { 1 + x % 2_500_000 };
        let log = killed_recording(d.path(), &format!("killed{k}.mcap"), kill_at);
        let out = speleo(&["replay", log.to_str().expect("utf8")]);
        let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
        assert!(
            !stderr.contains("panicked"),
            "kill at {kill_at} B: {stderr}"
        );
        if out.status.success() {
            assert_eq!(stdout.trim(), "identical", "kill at {kill_at} B: {stderr}");
        } else {
            // Too early for a whole frame: a clear refusal.
            assert!(
                stderr.contains("no complete frame") || stderr.contains("nothing to replay"),
                "kill at {kill_at} B: {stdout}{stderr}"
            );
        }
    }
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
        "--route",
        "--trace-allocations-over",
    ] {
        assert!(h.contains(opt), "{opt} missing from:\n{h}");
    }
    let h = text(&speleo(&["replay", "--help"]).stdout);
    assert!(h.contains("identical"), "{h}");
}

#[test]
fn large_allocations_of_the_tasks_are_traced_with_their_slot_and_backtrace() {
    let out = speleo(&[
        "sim",
        "--world",
        "flat",
        "--duration",
        "5",
        "--trace-allocations-over",
        "65536",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let e = text(&out.stderr);
    let traced = e
        .lines()
        .filter(|l| l.starts_with("allocation of "))
        .count();
    assert!(traced >= 1, "nothing traced:\n{e}");
    assert!(e.contains(" in slot ") && e.contains("speleo"), "{e}");
    // Not a number: refused with the option named.
    let bad = speleo(&["sim", "--trace-allocations-over", "lots"]);
    assert!(!bad.status.success());
    assert!(text(&bad.stderr).contains("--trace-allocations-over"));
}

#[test]
fn a_dumped_validation_replays_to_the_verdict_the_mission_got() {
    let d = tempfile::tempdir().expect("tmp");
    let dir = d.path().join("cases");
    let dirs = dir.to_str().expect("utf-8");
    let out = speleo(&[
        "sim",
        "--world",
        "flat",
        "--duration",
        "20",
        "--dump-validations",
        dirs,
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let case = dir.join("validation-0001.case");
    assert!(case.exists(), "{}", text(&out.stderr));
    let (mesh, track) = (d.path().join("w.ply"), d.path().join("t.csv"));
    let plan = d.path().join("p.csv");
    let r = speleo(&[
        "validate",
        case.to_str().expect("utf-8"),
        "--mesh",
        mesh.to_str().expect("utf-8"),
        "--track",
        track.to_str().expect("utf-8"),
        "--plan",
        plan.to_str().expect("utf-8"),
    ]);
    let o = text(&r.stdout);
    assert!(r.status.success(), "{o}{}", text(&r.stderr));
    assert!(o.contains("same verdict as on board"), "{o}");
    assert!(o.contains("replayed: Reached"), "{o}");
    let ply = std::fs::read(&mesh).expect("mesh");
    assert!(ply.starts_with(b"ply\n"), "a PLY");
    let rows = std::fs::read_to_string(&track).expect("track");
    assert!(rows.starts_with("t_s,x_m,y_m,z_m"), "{rows:.80}");
    assert!(rows.lines().count() > 100, "a row a physics step");
    // The plan as the case holds it: a header, then a pose a row, the
    // count the summary line gives.
    let poses = std::fs::read_to_string(&plan).expect("plan");
    assert!(poses.starts_with("x_m,y_m,z_m,yaw_deg\n"), "{poses:.80}");
    let n = poses.lines().count() - 1;
    assert!(n >= 2, "{poses}");
    assert!(o.contains(&format!("plan {n} poses")), "{o}");
    // The same plan on the world's true surface, placed by the true track
    // the simulation wrote beside the cases.
    assert!(dir.join("truth.csv").exists());
    let w = speleo(&["validate", case.to_str().expect("utf-8"), "--world", "flat"]);
    let o = text(&w.stdout);
    assert!(w.status.success(), "{o}{}", text(&w.stderr));
    assert!(o.contains("true world: Reached"), "{o}");
    assert!(o.contains("SLAM's error then"), "{o}");
    // Anything else is refused with the reason.
    let bad = speleo(&["validate", mesh.to_str().expect("utf-8")]);
    assert!(!bad.status.success());
    assert!(text(&bad.stderr).contains("not a validation case"));
}

fn shared(rel: &str) -> Option<std::path::PathBuf> {
    speleo_hal::shared_data::path(rel)
}

#[test]
fn decode_hdl32e_reproduces_veloviews_frames() {
    let (Some(pcap), Some(xml)) = (
        shared("velodyne/monterey-first-100-packets.pcap"),
        shared("velodyne/HDL-32.xml"),
    ) else {
        return;
    };
    let d = tempfile::tempdir().expect("tmp");
    let csv = d.path().join("f8.csv");
    let out = speleo(&[
        "decode",
        "hdl32e",
        pcap.to_str().expect("utf8"),
        "--calib",
        xml.to_str().expect("utf8"),
        "--interpolation",
        "veloview",
        "--csv",
        csv.to_str().expect("utf8"),
        "--frame",
        "8",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let o = text(&out.stdout);
    assert!(o.contains("frame 8: 49737 points"), "{o}");
    assert!(
        o.contains("19 frames, 872800 points from 2702 data packets"),
        "{o}"
    );
    assert!(o.contains("299 position packets"), "{o}");
    let rows = std::fs::read_to_string(&csv).expect("csv");
    assert_eq!(rows.lines().count(), 1 + 49737);
    assert!(rows.starts_with("frame,x,y,z,intensity,ring,time\n"));
}

#[test]
fn decode_xbus_and_can_report_counts() {
    let (Some(bin), Some(log)) = (
        shared("xsens/4/output.bin"),
        shared("can/ros2_canopen_issue225_candump_bootup.log"),
    ) else {
        return;
    };
    let out = speleo(&["decode", "xbus", bin.to_str().expect("utf8"), "--json"]);
    assert!(out.status.success());
    let o = text(&out.stdout);
    assert_eq!(o.lines().count(), 101);
    let last: serde_json::Value =
        serde_json::from_str(o.lines().last().expect("line")).expect("json");
    assert_eq!(last["summary"]["good_frames"], 100);
    assert_eq!(last["summary"]["bad_checksums"], 0);
    let first: serde_json::Value =
        serde_json::from_str(o.lines().next().expect("line")).expect("json");
    assert_eq!(first["items"]["Acceleration"]["precision"], "Float64");
    let out = speleo(&["decode", "can", log.to_str().expect("utf8")]);
    let o = text(&out.stdout);
    assert!(o.contains("heartbeat node 1: BootUp"), "{o}");
    assert!(o.contains("= 0x00020192 (CiA 402 drive)"), "{o}");
}

#[test]
fn an_imported_capture_replays_through_the_lidar_driver() {
    let Some(pcap) = shared("velodyne/monterey-first-100-packets.pcap") else {
        return;
    };
    let d = tempfile::tempdir().expect("tmp");
    let (imp, out_log, rep) = (
        d.path().join("imp.mcap"),
        d.path().join("out.mcap"),
        d.path().join("r.json"),
    );
    let s = |p: &Path| p.to_str().expect("utf8").to_string();
    let out = speleo(&["pcap2mcap", &s(&pcap), &s(&imp)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("2702 data packets, 299 position packets"));
    let out = speleo(&[
        "replay",
        &s(&imp),
        "--record",
        &s(&out_log),
        "--report",
        &s(&rep),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("imported capture"));
    // The replay's own recording replays identically, point clouds included.
    let out = speleo(&["replay", &s(&out_log)]);
    assert_eq!(
        text(&out.stdout).trim(),
        "identical",
        "{}",
        text(&out.stderr)
    );
    let bytes = std::fs::read(&out_log).expect("recording");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("present");
    let clouds = summary
        .channels
        .values()
        .find(|c| c.topic == "/lidar/points")
        .and_then(|c| {
            summary
                .stats
                .as_ref()
                .and_then(|s| s.channel_message_counts.get(&c.id).copied())
        })
        .unwrap_or(0);
    assert_eq!(clouds, 18, "revolutions completed in the capture");
}

#[test]
fn a_mission_starts_at_a_named_waypoint_standing_on_the_ground_there() {
    let dir = tempfile::tempdir().expect("tempdir");
    let r = dir.path().join("r.json");
    let r_s = r.to_str().expect("utf-8");
    // The garage's level 1, where the first ramp arrives.
    let out = speleo(&[
        "sim",
        "--world",
        "garage",
        "--start",
        "level1",
        "--duration",
        "2",
        "--report",
        r_s,
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&r).expect("report")).expect("json");
    let end = &v["exploration"]["end_position"];
    let at = |k: usize| end[k].as_f64().expect("end position");
    assert!(
        (at(0) - 17.0).abs() < 0.5 && (at(1) - 17.7).abs() < 0.5,
        "{end}"
    );
    // On level 1's deck (3 m), its base at axle height over it, not fallen
    // to level 0 nor dropped from high.
    assert!(at(2) > 3.0 && at(2) < 3.5, "{end}");
    assert_eq!(v["exploration"]["falls"], 0);
    assert_eq!(v["success"]["failure"], "out_of_time");

    let out = speleo(&[
        "sim",
        "--world",
        "garage",
        "--start",
        "level7",
        "--duration",
        "1",
    ]);
    assert!(!out.status.success());
    let e = text(&out.stderr);
    assert!(e.contains("level7") && e.contains("level1"), "{e}");
}
