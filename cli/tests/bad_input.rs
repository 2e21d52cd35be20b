//! Bad input to the ground tools, as a user gives it: each gets an error
//! naming the problem and a non-zero exit, never a panic or a silent
//! success.

use std::path::Path;
use std::process::{Command, Stdio};

mod common;
use common::speleo;

/// The command fails (exit status 1 or 2, not a panic's 101) and its
/// standard error holds every one of `words`.
fn refused(args: &[&str], words: &[&str]) {
    let out = speleo(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        matches!(out.status.code(), Some(1 | 2)),
        "{args:?}: status {:?}, {err}",
        out.status
    );
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    for w in words {
        assert!(err.contains(w), "{args:?}: no \"{w}\" in {err}");
    }
}

fn path(p: &Path) -> &str {
    p.to_str().expect("utf8")
}

#[test]
fn a_pose_graph_that_cannot_be_optimised_says_why() {
    let d = tempfile::tempdir().expect("tmp");
    let edge = "1 0 0 1 0 0 1 0 1";
    let vertices = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";
    let cases = [
        (
            format!("{vertices}EDGE_SE2 0 1 {edge}\nEDGE_SE2 1 5 {edge}\n"),
            vec!["line 4", "vertex 5"],
        ),
        (vertices.to_string(), vec!["no edges"]),
        (
            format!("{vertices}EDGE_SE2 0 1 1 0 0 0 0 0 0 0 0\n"),
            vec!["line 3", "not positive definite"],
        ),
        (
            format!("{vertices}VERTEX_SE2 2 2 0 0\nEDGE_SE2 0 1 {edge}\n"),
            vec!["vertex 2", "undetermined"],
        ),
    ];
    for (k, (text, words)) in cases.iter().enumerate() {
        let f = d.path().join(format!("g{k}.g2o"));
        std::fs::write(&f, text).expect("write");
        refused(&["g2o", path(&f)], words);
    }
}

/// An ASCII PLY of `n` points on a small grid.
fn cloud(p: &Path, n: usize) {
    let mut s = format!("ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n");
    for k in 0..n {
        s += &format!(
            "{} {} {}\n",
            (k % 7) as f64 * 0.1,
            (k / 7) as f64 * 0.1,
            0.01 * k as f64
        );
    }
    std::fs::write(p, s).expect("write");
}

#[test]
fn too_few_points_to_register_are_refused_and_not_called_converged() {
    let d = tempfile::tempdir().expect("tmp");
    let (three, many) = (d.path().join("three.ply"), d.path().join("many.ply"));
    cloud(&three, 3);
    cloud(&many, 200);
    refused(
        &["register", path(&three), path(&many)],
        &["too few points", "usable source"],
    );
    // A voxel larger than the cloud leaves one point of each.
    refused(
        &["register", path(&many), path(&many), "--voxel", "100"],
        &["too few points", "--voxel"],
    );
}

#[test]
fn settings_out_of_range_are_refused_before_any_work() {
    let d = tempfile::tempdir().expect("tmp");
    let out = d.path().join("m.ply");
    for blocks in ["100000000000", "0"] {
        refused(
            &[
                "mesh",
                "--scans",
                path(d.path()),
                "--poses",
                path(&d.path().join("poses.txt")),
                "--out",
                path(&out),
                "--max-blocks",
                blocks,
            ],
            &["--max-blocks", blocks],
        );
    }
    let env = d.path().join("env.cfg");
    for (flag, value) in [
        ("--eps", "0.5"),
        ("--eps", "NaN"),
        ("--eps-step", "0"),
        ("--quantum", "0"),
    ] {
        refused(&["plan", "--sbpl-env", path(&env), flag, value], &[flag]);
    }
}

#[test]
fn captures_and_logs_with_nothing_to_decode_say_so() {
    let d = tempfile::tempdir().expect("tmp");
    let random = d.path().join("random.bin");
    let bytes: Vec<u8> = (0u32..4096)
        .map(|k| (k.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    std::fs::write(&random, bytes).expect("write");
    refused(&["decode", "xbus", path(&random)], &["no Xbus frame"]);
    let empty = d.path().join("empty.log");
    std::fs::write(&empty, "").expect("write");
    refused(&["decode", "can", path(&empty)], &["no CAN frame"]);
    let pcap = d.path().join("empty.pcap");
    std::fs::write(&pcap, "").expect("write");
    refused(
        &["decode", "hdl32e", path(&pcap)],
        &["empty.pcap", "shorter than a pcap file header"],
    );
    refused(&["decode", "hdl32e", path(d.path())], &["a directory"]);
    let calib = d.path().join("calib.xml");
    std::fs::write(&calib, "\n").expect("write");
    refused(
        &["decode", "hdl32e", path(&pcap), "--calib", path(&calib)],
        &["calib.xml", "empty"],
    );
}

#[test]
fn a_listing_whose_reader_goes_away_ends_quietly() {
    // A listing piped into `head -0`: the pipe is closed before the first
    // line is written.
    let mut child = Command::new(env!("CARGO_BIN_EXE_speleo"))
        .args(["world", "waypoints", "short-tube"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("speleo runs");
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("waits");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}: {err}", out.status);
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn a_twin_with_bad_wires_or_faults_is_refused_before_it_starts() {
    let d = tempfile::tempdir().expect("tmp");
    refused(
        &["twin", "--unplug-lidar", "5", "--duration", "1"],
        &["--unplug-lidar 5", "AT:SECONDS"],
    );
    let cfg = d.path().join("twin.toml");
    std::fs::write(&cfg, "[twin]\nlidar_to = \"nowhere\"\n").expect("write");
    refused(
        &["twin", "--config", path(&cfg)],
        &["twin.lidar_to", "IP:PORT"],
    );
    std::fs::write(&cfg, "[twin]\nimu_lnk = \"/tmp/x\"\n").expect("write");
    refused(&["twin", "--config", path(&cfg)], &["imu_lnk"]);
}
