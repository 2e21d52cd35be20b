//! Replay reproduces a recording exactly and names the first divergence of a
//! tampered one.

use std::process::ExitCode;

use speleo_tests::{flip_raw_byte, read_json, replay, rewrite_mcap, sim, Scratch};

#[test]
fn replay_of_a_recording_is_identical() {
    let s = Scratch::new();
    let log = s.path("a.mcap");
    sim(3, 15.0, Some(&log), Some(&s.path("a.json")));
    assert_eq!(replay(&log, Some(&s.path("r.json"))), ExitCode::SUCCESS);
    let (a, r) = (read_json(&s.path("a.json")), read_json(&s.path("r.json")));
    assert_eq!(r["replay"]["identical"], true);
    assert_eq!(a["output_hash"], r["output_hash"]);
    assert!(r["replay"]["compared_messages"].as_u64().unwrap_or(0) > 5000);
    assert_eq!(r["scheduler"]["allocations_after_init"], 0);
}

#[test]
fn a_changed_encoder_byte_is_reported_with_topic_frame_and_field() {
    let s = Scratch::new();
    let log = s.path("a.mcap");
    sim(3, 5.0, Some(&log), None);
    // Frame 200, second CAN frame of the frame: node 1's TPDO2 (position);
    // byte 8 is the position's least significant byte.
    let bad = s.path("bad.mcap");
    let mut seen = 0;
    let edited = rewrite_mcap(&log, &bad, |topic, seq, data| {
        if topic == "/raw/can" && seq == 200 {
            seen += 1;
            if seen == 2 {
                return Some(flip_raw_byte(data, 8, 0x01));
            }
        }
        None
    });
    assert_eq!(edited, 1);
    let report = s.path("r.json");
    assert_eq!(replay(&bad, Some(&report)), ExitCode::FAILURE);
    let r = read_json(&report);
    let d = r["replay"]["divergence"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    assert_eq!(r["replay"]["identical"], false);
    assert!(d.contains("topic /drives"), "{d}");
    assert!(d.contains("frame 200"), "{d}");
    assert!(d.contains("wheels[0].position_counts"), "{d}");
}

#[test]
fn a_corrupted_imu_frame_is_reported() {
    let s = Scratch::new();
    let log = s.path("a.mcap");
    sim(3, 5.0, Some(&log), None);
    let bad = s.path("bad.mcap");
    let edited = rewrite_mcap(&log, &bad, |topic, seq, data| {
        (topic == "/raw/imu" && seq == 123).then(|| flip_raw_byte(data, 20, 0x10))
    });
    assert_eq!(edited, 1);
    let report = s.path("r.json");
    assert_eq!(replay(&bad, Some(&report)), ExitCode::FAILURE);
    let d = read_json(&report)["replay"]["divergence"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    // The checksum no longer holds: the sample is dropped, so the /imu output
    // of that frame is missing.
    assert!(d.contains("topic /imu,"), "{d}");
    assert!(d.contains("frame 123"), "{d}");
}
