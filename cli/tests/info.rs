//! `speleo info` on a finished recording, on one cut short, and on a file
//! that is not a recording.

mod common;
use common::{speleo, text};

#[test]
fn info_tells_topics_counts_and_whether_the_recording_was_finished() {
    let d = tempfile::tempdir().expect("tmp");
    let rec = d.path().join("r.mcap");
    let r = rec.to_str().expect("utf8");
    let out = speleo(&["sim", "--world", "flat", "--duration", "3", "--record", r]);
    assert!(out.status.success(), "{}", text(&out.stderr));

    let out = speleo(&["info", r, "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(v["summary"], true, "{v}");
    assert_eq!(v["indexed"], true, "{v}");
    assert!(v["cut_short"].is_null(), "{v}");
    let topics = v["topics"].as_array().expect("topics");
    let count = |name: &str| {
        topics
            .iter()
            .find(|t| t["topic"] == name)
            .and_then(|t| t["messages"].as_u64())
            .unwrap_or(0)
    };
    // The IMU's 100 samples a second for 3 s, and its rate.
    assert_eq!(count("/raw/imu"), 300, "{v}");
    let imu = topics
        .iter()
        .find(|t| t["topic"] == "/raw/imu")
        .expect("imu");
    let hz = imu["rate_hz"].as_f64().expect("rate");
    assert!((95.0..=105.0).contains(&hz), "{hz}");
    let sum: u64 = topics.iter().filter_map(|t| t["messages"].as_u64()).sum();
    assert_eq!(v["messages"].as_u64(), Some(sum));
    let d_s = v["duration_s"].as_f64().expect("duration");
    assert!(d_s > 2.5 && d_s <= 3.0, "{d_s}");
    assert_eq!(v["run"]["mode"], "sim");
    assert!(
        v["config"].as_str().is_some_and(|c| c.contains("[sim]")),
        "{v}"
    );
    assert!(v["outcome"]["output_hash"].is_string(), "{v}");

    let out = speleo(&["info", r]);
    let o = text(&out.stdout);
    assert!(o.contains("finished:    yes"), "{o}");
    assert!(
        o.contains("/lidar/points") && o.contains("sensor_msgs/msg/PointCloud2"),
        "{o}"
    );

    // Cut in the middle, as a killed writer leaves it: read to the break.
    let bytes = std::fs::read(&rec).expect("read");
    let cut = d.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("write");
    let out = speleo(&["info", cut.to_str().expect("utf8"), "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let c: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(c["summary"], false, "{c}");
    assert!(c["cut_short"].is_string(), "{c}");
    let n = c["messages"].as_u64().expect("messages");
    assert!(n > 0 && n < sum, "{n} of {sum}");

    let not = d.path().join("not.mcap");
    std::fs::write(&not, "hello").expect("write");
    let out = speleo(&["info", not.to_str().expect("utf8")]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("not an MCAP recording"));
}
