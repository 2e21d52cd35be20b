//! Every channel is a ROS 2 message with its schema, every recorded message
//! decodes exactly through that schema (so schemas cannot drift from the
//! messages), and the file reads back with the mcap crate's standard readers
//! (summary, indexed messages, linear stream).

use std::collections::BTreeSet;

use speleo_tests::{sim, MessageDecoder, Scratch};

#[test]
fn every_message_decodes_through_its_channels_ros2_schema() {
    let s = Scratch::new();
    let log = s.path("a.mcap");
    sim(1, 3.0, Some(&log), None);
    let bytes = std::fs::read(&log).expect("read");
    let header = mcap::read::LinearReader::new(&bytes)
        .expect("linear reader")
        .next()
        .expect("a record")
        .expect("the header");
    match header {
        mcap::records::Record::Header(h) => assert_eq!(h.profile, "ros2"),
        other => panic!("first record is not the header: {other:?}"),
    }
    let summary = mcap::Summary::read(&bytes)
        .expect("summary parses")
        .expect("summary present");
    assert!(!summary.channels.is_empty());
    for c in summary.channels.values() {
        let schema = c
            .schema
            .as_ref()
            .unwrap_or_else(|| panic!("{} has no schema", c.topic));
        assert_eq!(schema.encoding, "ros2msg", "{}", c.topic);
        assert_eq!(c.message_encoding, "cdr", "{}", c.topic);
        assert!(schema.name.contains("/msg/"), "{}", schema.name);
        let qos = &c.metadata["offered_qos_profiles"];
        assert!(qos.contains("reliability: 1"), "{}", c.topic);
    }
    let names: Vec<&str> = summary
        .channels
        .values()
        .map(|c| c.topic.as_str())
        .collect();
    for t in [
        "/odom",
        "/tf",
        "/tf_static",
        "/raw/imu",
        "/raw/can",
        "/raw/lidar",
        "/lidar/points",
        "/imu",
        "/diagnostics",
        "/scheduler",
        "/plan",
    ] {
        assert!(names.contains(&t), "missing {t}");
    }
    // Every message of every channel, through its schema: a field written
    // but not declared, or declared but not written, fails here.
    let mut decoder = MessageDecoder::default();
    let mut frames = BTreeSet::new();
    let mut decoded = BTreeSet::new();
    for m in mcap::MessageStream::new(&bytes).expect("stream") {
        let m = m.expect("message");
        let v = decoder.decode(&m);
        decoded.insert(m.channel.topic.clone());
        if let Some(ts) = v["transforms"].as_array() {
            for t in ts {
                let parent = t["header"]["frame_id"]
                    .as_str()
                    .expect("parent")
                    .to_string();
                let child = t["child_frame_id"].as_str().expect("child").to_string();
                frames.insert((parent, child));
            }
        }
    }
    // One tree: world -> map -> odom -> base_link -> sensors.
    for (parent, child) in [
        ("world", "map"),
        ("odom", "base_link"),
        ("base_link", "lidar"),
        ("base_link", "imu"),
    ] {
        assert!(
            frames.contains(&(parent.to_string(), child.to_string())),
            "no {parent} -> {child} in {frames:?}"
        );
    }
    assert!(decoded.len() >= 15, "{decoded:?}");
    let stats = summary.stats.as_ref().expect("statistics");
    let mut n = 0u64;
    let mut clouds = 0;
    for m in mcap::MessageStream::new(&bytes).expect("stream") {
        let m = m.expect("message");
        if m.channel.topic == "/lidar/points" {
            // A CDR PointCloud2 of 20-byte points: the data is most of it.
            assert!(m.data.len() > 20 * 10_000, "{}", m.data.len());
            clouds += 1;
        }
        n += 1;
    }
    assert!(clouds >= 1, "the default simulation records point clouds");
    assert_eq!(n, stats.message_count);
    // log_time is the frame time, sequence the frame number.
    for m in mcap::MessageStream::new(&bytes).expect("stream").take(200) {
        let m = m.expect("message");
        let frame_time = m.log_time - 1_767_225_600_000_000_000;
        assert_eq!(frame_time, m.sequence as u64 * 10_000_000);
    }
}
