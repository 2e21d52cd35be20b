//! The twin's own recording (MCAP, ROS 2 profile): the rover's true pose,
//! every byte it sent the flight binary and every byte it received from it.
//! A thread writes the file; the real-time loop hands it messages through a
//! bounded queue and counts what a full queue made it drop.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TrySendError};
use std::thread::JoinHandle;

use speleo_firmware::record::cdr::write_raw_input;
use speleo_firmware::record::encode::Time;
use speleo_firmware::record::ros2::pose_stamped;
use speleo_firmware::record::schemas;

/// The twin's channels: name, schema name, schema text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Track {
    /// The true pose of base_link in the world (`/sim/ground_truth`, as in
    /// a `sim` recording).
    Truth,
    /// HDL-32E data packets sent.
    LidarSent,
    /// HDL-32E position packets sent.
    LidarPositionSent,
    /// Xbus bytes the MTi twin sent.
    ImuSent,
    /// Bytes the flight binary wrote to the MTi.
    ImuReceived,
    /// slcan bytes the adapter twin sent (frames from the drives, answers).
    CanSent,
    /// slcan bytes the flight binary wrote to the adapter.
    CanReceived,
}

impl Track {
    pub const ALL: [Track; 7] = [
        Track::Truth,
        Track::LidarSent,
        Track::LidarPositionSent,
        Track::ImuSent,
        Track::ImuReceived,
        Track::CanSent,
        Track::CanReceived,
    ];

    pub fn topic(self) -> &'static str {
        match self {
            Track::Truth => "/sim/ground_truth",
            Track::LidarSent => "/twin/lidar/sent",
            Track::LidarPositionSent => "/twin/lidar_position/sent",
            Track::ImuSent => "/twin/imu/sent",
            Track::ImuReceived => "/twin/imu/received",
            Track::CanSent => "/twin/can/sent",
            Track::CanReceived => "/twin/can/received",
        }
    }

    /// The `device` field of its raw messages.
    fn device(self) -> &'static str {
        match self {
            Track::Truth => "",
            Track::LidarSent => "lidar",
            Track::LidarPositionSent => "lidar_position",
            Track::ImuSent | Track::ImuReceived => "imu",
            Track::CanSent | Track::CanReceived => "can_slcan",
        }
    }

    fn channel_id(self) -> u16 {
        Track::ALL.iter().position(|t| *t == self).unwrap_or(0) as u16 + 1
    }
}

/// Messages the queue holds at most: about two seconds of traffic.
const QUEUE: usize = 8192;

struct Message {
    track: Track,
    log_time: u64,
    data: Vec<u8>,
}

/// The recording being written.
pub struct Tape {
    tx: Option<SyncSender<Message>>,
    thread: Option<JoinHandle<Result<u64, String>>>,
    epoch_ns: u64,
    /// Messages a full queue dropped.
    pub dropped: u64,
    path: PathBuf,
}

impl Tape {
    /// Create `path` and start writing; `meta` becomes the `speleo.twin`
    /// metadata record. Times count from the Unix epoch until
    /// [`Tape::begin`] says when the twin's time zero is.
    pub fn create(path: &Path, meta: BTreeMap<String, String>) -> Result<Tape, String> {
        let file =
            File::create(path).map_err(|e| format!("cannot create {}: {e}", path.display()))?;
        let mut w = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("speleo twin ", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .create(BufWriter::new(file))
            .map_err(|e| format!("{}: {e}", path.display()))?;
        let err = |e: mcap::McapError| format!("{}: {e}", path.display());
        let pose = w
            .add_schema(
                "geometry_msgs/msg/PoseStamped",
                "ros2msg",
                schemas::POSE_STAMPED.as_bytes(),
            )
            .map_err(err)?;
        let raw = w
            .add_schema(
                "speleo_msgs/msg/RawInput",
                "ros2msg",
                schemas::RAW_INPUT.as_bytes(),
            )
            .map_err(err)?;
        for t in Track::ALL {
            let schema = if t == Track::Truth { pose } else { raw };
            w.add_channel_with_id(t.channel_id(), schema, t.topic(), "cdr", &BTreeMap::new())
                .map_err(err)?;
        }
        w.write_metadata(&mcap::records::Metadata {
            name: "speleo.twin".into(),
            metadata: meta,
        })
        .map_err(err)?;
        let (tx, rx) = sync_channel(QUEUE);
        let shown = path.display().to_string();
        let thread = std::thread::Builder::new()
            .name("twin-tape".into())
            .spawn(move || write_all(w, rx, &shown))
            .map_err(|e| format!("cannot start the recording thread: {e}"))?;
        Ok(Tape {
            tx: Some(tx),
            thread: Some(thread),
            epoch_ns: 0,
            dropped: 0,
            path: path.to_path_buf(),
        })
    }

    /// The twin's time zero is `epoch_ns` (Unix ns): its clock starts.
    pub fn begin(&mut self, epoch_ns: u64) {
        self.epoch_ns = epoch_ns;
    }

    /// Record bytes on `track` at twin time `t_ns`.
    pub fn raw(&mut self, track: Track, t_ns: u64, bytes: &[u8]) {
        let stamp = Time::from_ns(self.epoch_ns + t_ns);
        let mut data = Vec::with_capacity(bytes.len() + 32);
        if write_raw_input(&mut data, stamp.sec, stamp.nsec, track.device(), bytes).is_ok() {
            self.push(track, t_ns, data);
        }
    }

    /// Record the true pose at twin time `t_ns`.
    pub fn truth(&mut self, t_ns: u64, position: [f64; 3], orientation: [f64; 4]) {
        let mut data = Vec::with_capacity(96);
        let stamp = Time::from_ns(self.epoch_ns + t_ns);
        if pose_stamped(&mut data, stamp, "world", position, orientation).is_ok() {
            self.push(Track::Truth, t_ns, data);
        }
    }

    fn push(&mut self, track: Track, t_ns: u64, data: Vec<u8>) {
        let Some(tx) = &self.tx else { return };
        let m = Message {
            track,
            log_time: self.epoch_ns + t_ns,
            data,
        };
        match tx.try_send(m) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => self.dropped += 1,
        }
    }

    /// Finish the file (summary and index); the messages written.
    pub fn finish(mut self) -> Result<u64, String> {
        drop(self.tx.take());
        match self.thread.take().map(JoinHandle::join) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(format!(
                "{}: the recording thread failed",
                self.path.display()
            )),
            None => Ok(0),
        }
    }
}

fn write_all(
    mut w: mcap::Writer<BufWriter<File>>,
    rx: Receiver<Message>,
    path: &str,
) -> Result<u64, String> {
    let err = |e: mcap::McapError| format!("{path}: {e}");
    let mut sequences = [0u32; Track::ALL.len()];
    let mut written = 0;
    for m in rx {
        let seq = &mut sequences[m.track.channel_id() as usize - 1];
        *seq += 1;
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: m.track.channel_id(),
                sequence: *seq,
                log_time: m.log_time,
                publish_time: m.log_time,
            },
            &m.data,
        )
        .map_err(err)?;
        written += 1;
    }
    w.finish().map_err(err)?;
    Ok(written)
}
