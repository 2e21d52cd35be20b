//! Every channel has a schema and the file reads back with the mcap crate's
//! standard readers (summary, indexed messages, linear stream).

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
        assert_eq!(schema.encoding, "jsonschema", "{}", c.topic);
        assert_eq!(c.message_encoding, "json", "{}", c.topic);
        let v: serde_json::Value = serde_json::from_slice(&schema.data).expect("schema is JSON");
        assert_eq!(v["title"], schema.name.as_str());
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
        "/health",
        "/scheduler",
        "/plan",
    ] {
        assert!(names.contains(&t), "missing {t}");
    }
    let stats = summary.stats.as_ref().expect("statistics");
    let mut n = 0u64;
    for m in mcap::MessageStream::new(&bytes).expect("stream") {
        let m = m.expect("message");
        let _: serde_json::Value = serde_json::from_slice(&m.data).expect("message is JSON");
        n += 1;
    }
    assert_eq!(n, stats.message_count);
    // log_time is the frame time, sequence the frame number.
    for m in mcap::MessageStream::new(&bytes).expect("stream").take(200) {
        let m = m.expect("message");
        let frame_time = m.log_time - 1_767_225_600_000_000_000;
        assert_eq!(frame_time, m.sequence as u64 * 10_000_000);
    }
}
