//! Every channel has a schema and the file reads back with the mcap crate's
//! standard readers (summary, indexed messages, linear stream).

use speleo_firmware::record::cdr::read_raw_input;
use speleo_tests::{sim, Scratch};

#[test]
fn every_channel_has_a_schema_and_the_file_reads_back() {
    let s = Scratch::new();
    let log = s.path("a.mcap");
    sim(1, 3.0, Some(&log), None);
    let bytes = std::fs::read(&log).expect("read");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary parses")
        .expect("summary present");
    assert!(!summary.channels.is_empty());
    for c in summary.channels.values() {
        let schema = c
            .schema
            .as_ref()
            .unwrap_or_else(|| panic!("{} has no schema", c.topic));
        if c.message_encoding == "cdr" {
            // Raw bytes and point clouds: ROS 2 message definitions.
            assert_eq!(schema.encoding, "ros2msg", "{}", c.topic);
            let text = std::str::from_utf8(&schema.data).expect("schema is text");
            assert!(text.contains("MSG: builtin_interfaces/Time"), "{}", c.topic);
        } else {
            assert_eq!(schema.encoding, "jsonschema", "{}", c.topic);
            assert_eq!(c.message_encoding, "json", "{}", c.topic);
            let v: serde_json::Value =
                serde_json::from_slice(&schema.data).expect("schema is JSON");
            assert_eq!(v["title"], schema.name.as_str());
        }
    }
    let names: Vec<&str> = summary
        .channels
        .values()
        .map(|c| c.topic.as_str())
        .collect();
    for t in [
        "/odom",
        "/tf",
        "/raw/imu",
        "/raw/can",
        "/raw/lidar",
        "/lidar/points",
        "/health",
        "/scheduler",
        "/plan",
    ] {
        assert!(names.contains(&t), "missing {t}");
    }
    let stats = summary.stats.as_ref().expect("statistics");
    let mut n = 0u64;
    let mut clouds = 0;
    for m in mcap::MessageStream::new(&bytes).expect("stream") {
        let m = m.expect("message");
        match (
            m.channel.message_encoding.as_str(),
            m.channel.topic.as_str(),
        ) {
            ("cdr", "/lidar/points") => {
                // A CDR PointCloud2 of 20-byte points: little-endian header,
                // then the stamp; the data is most of the message.
                assert_eq!(&m.data[..2], &[0, 1]);
                assert!(m.data.len() > 20 * 10_000, "{}", m.data.len());
                clouds += 1;
            }
            ("cdr", _) => {
                let raw = read_raw_input(&m.data).expect("a CDR RawInput");
                assert!(!raw.data.is_empty());
            }
            _ => {
                let _: serde_json::Value =
                    serde_json::from_slice(&m.data).expect("message is JSON");
            }
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
