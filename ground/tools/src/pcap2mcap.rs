//! `speleo pcap2mcap`: turn a LiDAR capture into a recording `speleo replay`
//! runs. Every datagram to the data (2368) or position (8308) port becomes a
//! raw input, in the minor frame of its capture time (time 0 = the first
//! one); nothing else of the capture is kept.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::Path;

use speleo_hal::hdl32e::{DATA_PORT, POSITION_PORT};
use speleo_hal::pcap::read_udp;

use crate::Error;
use speleo_firmware::config::Config;
use speleo_firmware::mission::cloud_message_capacity;
use speleo_firmware::record::writer::{self, WriterOptions};
use speleo_firmware::record::{RecorderTap, Topic};

pub struct ImportSummary {
    pub data_packets: u64,
    pub position_packets: u64,
    pub other: u64,
    pub frames: u64,
}

pub fn run(capture: &Path, out: &Path, cfg: &Config) -> Result<ImportSummary, Error> {
    let (dgrams, counters) = read_udp(capture)?;
    let mut kept = dgrams
        .into_iter()
        .filter(|d| d.dst.port() == DATA_PORT || d.dst.port() == POSITION_PORT)
        .peekable();
    let Some(t0) = kept.peek().map(|d| d.time_ns) else {
        return Err(format!(
            "{}: no datagram to UDP port {DATA_PORT} or {POSITION_PORT}",
            capture.display()
        )
        .into());
    };
    let minor_ns = cfg.executive.minor_frame_us as u64 * 1000;
    let mut meta = BTreeMap::new();
    meta.insert("config".into(), cfg.to_toml());
    meta.insert("mode".into(), "import".into());
    meta.insert(
        "minor_frame_us".into(),
        cfg.executive.minor_frame_us.to_string(),
    );
    meta.insert("source".into(), capture.display().to_string());
    meta.insert("speleo_version".into(), env!("CARGO_PKG_VERSION").into());
    let large = cloud_message_capacity(cfg.lidar.max_points_per_frame);
    let h = writer::spawn(WriterOptions {
        path: Some(out.to_path_buf()),
        live: None,
        zstd: cfg.record.compression == "zstd",
        chunk_size: cfg.record.chunk_size_kib as u64 * 1024,
        pool: cfg.record.pool_messages as usize,
        large_pool: 1,
        large_capacity: 4096,
        run_metadata: meta,
    })?;
    let thread = h.thread.thread().clone();
    let mut tap =
        RecorderTap::new(None, large).with_writer(h.tx, h.pool, h.large_pool, thread, true);
    tap.begin(t0);
    let tap = RefCell::new(tap);
    let mut s = ImportSummary {
        data_packets: 0,
        position_packets: 0,
        other: counters.other + counters.udp,
        frames: 0,
    };
    let mut last_t = t0;
    for d in kept {
        // Capture times can step back a little (several capture queues);
        // frames never do.
        let t = d.time_ns.max(last_t) - t0;
        last_t = d.time_ns.max(last_t);
        let frame = t / minor_ns;
        let (topic, device) = if d.dst.port() == DATA_PORT {
            s.data_packets += 1;
            (Topic::RawLidar, "lidar")
        } else {
            s.position_packets += 1;
            (Topic::RawLidarPosition, "lidar_position")
        };
        tap.borrow_mut()
            .raw(topic, device, frame, frame * minor_ns, t, &d.payload);
        s.frames = frame + 1;
    }
    s.other -= s.data_packets + s.position_packets;
    let mut summary = BTreeMap::new();
    summary.insert("frames".into(), s.frames.to_string());
    summary.insert("imported".into(), "true".into());
    tap.borrow_mut().finish(summary);
    match h.thread.join() {
        Ok(Ok(_)) => Ok(s),
        Ok(Err(e)) => Err(e.into()),
        Err(_) => Err("the recording thread panicked".into()),
    }
}
