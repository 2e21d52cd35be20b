//! The MCAP writer thread.
//!
//! The executive never touches the file: the recorder task serialises each
//! message into a buffer taken from a pool allocated at start-up and hands it
//! to this thread, which writes it and returns the buffer. Compression and
//! file I/O therefore cost the frame nothing and allocate nothing on the
//! executive's thread. Chunks go straight to the file when they close, so a
//! killed process loses at most the open chunk.
//!
//! Messages and buffers travel through two wait-free single-producer rings
//! (`rtrb`), which never allocate after creation (a blocking std channel
//! registers a waker on the heap the first time a thread waits on it). A side
//! that must wait parks with a timeout and is unparked by the other.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::thread::{JoinHandle, Thread};
use std::time::Duration;

use super::topics::Topic;
use crate::record::live::LiveServer;

/// Capacity of one pooled message buffer.
pub const MESSAGE_CAPACITY: usize = 16 * 1024;

pub struct Outgoing {
    pub topic: Topic,
    /// The buffer belongs to the large pool.
    pub large: bool,
    pub sequence: u32,
    pub log_time: u64,
    pub publish_time: u64,
    pub buf: Vec<u8>,
}

pub enum WriterMsg {
    /// The recording's time base, Unix ns at mission time 0: the
    /// `speleo.run` metadata is written with it, before any message.
    Begin(u64),
    Message(Outgoing),
    /// Write a metadata record (e.g. the run summary) and finish the file.
    Finish(BTreeMap<String, String>),
}

#[derive(Clone)]
pub struct WriterOptions {
    /// The MCAP file; `None` when the messages only go to the live view.
    pub path: Option<PathBuf>,
    /// The live view, offered every message after it is written.
    pub live: Option<Arc<LiveServer>>,
    pub zstd: bool,
    pub chunk_size: u64,
    pub pool: usize,
    /// Buffers for point clouds: how many, and how large.
    pub large_pool: usize,
    pub large_capacity: usize,
    /// Written as the `speleo.run` metadata record, with `epoch_ns` from
    /// [`WriterMsg::Begin`], before any message.
    pub run_metadata: BTreeMap<String, String>,
}

/// What the writer thread reports when it ends.
#[derive(Clone, Debug, Default)]
pub struct WriterStats {
    pub messages: u64,
    pub bytes: u64,
}

pub struct WriterHandle {
    pub tx: rtrb::Producer<WriterMsg>,
    pub pool: rtrb::Consumer<Vec<u8>>,
    pub large_pool: rtrb::Consumer<Vec<u8>>,
    pub thread: JoinHandle<Result<WriterStats, String>>,
}

/// Longest nap of a side waiting for the other (it is normally unparked).
pub const NAP: Duration = Duration::from_millis(2);

fn open(path: &Path, opts: &WriterOptions) -> Result<mcap::Writer<File>, String> {
    let file = File::create(path).map_err(|e| format!("cannot create {}: {e}", path.display()))?;
    start(file, path, opts)
}

/// Start a recording on `sink`: header, schemas and channels.
fn start<W: Write + Seek>(
    sink: W,
    path: &Path,
    opts: &WriterOptions,
) -> Result<mcap::Writer<W>, String> {
    let mut w = mcap::WriteOptions::new()
        // rosbag2's profile: ROS 2 tools open the file as a bag.
        .profile("ros2")
        .library(concat!("speleo ", env!("CARGO_PKG_VERSION")))
        .compression(opts.zstd.then_some(mcap::Compression::Zstd))
        .chunk_size(Some(opts.chunk_size))
        // Each chunk is built in memory and written whole. Written in place,
        // a chunk's header is patched field by field after its data, and a
        // writer killed between two of those writes leaves a chunk whose
        // length is final but whose sizes are placeholders: replay would
        // have to call it damage instead of a cut.
        .disable_seeking(true)
        .compression_threads(0)
        .create(sink)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let mut schema_ids: BTreeMap<&str, u16> = BTreeMap::new();
    for t in Topic::ALL {
        let i = t.info();
        let sid = match schema_ids.get(i.schema) {
            Some(id) => *id,
            None => {
                let id = w
                    .add_schema(i.schema, i.schema_encoding(), i.schema_data.as_bytes())
                    .map_err(|e| e.to_string())?;
                schema_ids.insert(i.schema, id);
                id
            }
        };
        let mut meta = BTreeMap::new();
        meta.insert("speleo.role".to_string(), i.role.as_str().to_string());
        meta.insert(
            "offered_qos_profiles".to_string(),
            i.offered_qos().to_string(),
        );
        w.add_channel_with_id(t.channel_id(), sid, i.name, i.message_encoding(), &meta)
            .map_err(|e| e.to_string())?;
    }
    Ok(w)
}

/// The `speleo.run` record: the run's metadata and its time base.
fn write_run<W: Write + Seek>(
    w: &mut mcap::Writer<W>,
    run: &BTreeMap<String, String>,
    epoch_ns: Option<u64>,
) -> Result<(), mcap::McapError> {
    let mut metadata = run.clone();
    if let Some(e) = epoch_ns {
        metadata.insert("epoch_ns".into(), e.to_string());
    }
    w.write_metadata(&mcap::records::Metadata {
        name: "speleo.run".into(),
        metadata,
    })
}

/// Create the file and start the thread. The file is created before this
/// returns, so a bad path is reported at start-up. Call it on the thread that
/// will record: that thread is unparked when buffers come back.
pub fn spawn(opts: WriterOptions) -> Result<WriterHandle, String> {
    let mut w = opts.path.as_deref().map(|p| open(p, &opts)).transpose()?;
    // Two more slots than buffers, for the opening and closing messages.
    let (tx, rx) = rtrb::RingBuffer::<WriterMsg>::new(opts.pool + opts.large_pool + 2);
    let (mut pool_tx, pool_rx) = rtrb::RingBuffer::<Vec<u8>>::new(opts.pool);
    for _ in 0..opts.pool {
        let _ = pool_tx.push(Vec::with_capacity(MESSAGE_CAPACITY));
    }
    let (mut large_tx, large_rx) = rtrb::RingBuffer::<Vec<u8>>::new(opts.large_pool.max(1));
    for _ in 0..opts.large_pool {
        let _ = large_tx.push(Vec::with_capacity(opts.large_capacity));
    }
    let path = opts.path.clone().unwrap_or_default();
    let live = opts.live.clone();
    let run_metadata = opts.run_metadata;
    let recorder = std::thread::current();
    let thread = std::thread::Builder::new()
        .name("mcap-writer".into())
        .spawn(move || {
            run(
                w.as_mut(),
                &path,
                &run_metadata,
                live.as_deref(),
                rx,
                [pool_tx, large_tx],
                recorder,
            )
        })
        .map_err(|e| format!("cannot start the writer thread: {e}"))?;
    Ok(WriterHandle {
        tx,
        pool: pool_rx,
        large_pool: large_rx,
        thread,
    })
}

fn run(
    mut w: Option<&mut mcap::Writer<File>>,
    path: &Path,
    run_metadata: &BTreeMap<String, String>,
    live: Option<&LiveServer>,
    mut rx: rtrb::Consumer<WriterMsg>,
    mut pools: [rtrb::Producer<Vec<u8>>; 2],
    recorder: Thread,
) -> Result<WriterStats, String> {
    let err = |e: mcap::McapError| format!("{}: {e}", path.display());
    let mut stats = WriterStats::default();
    let mut summary = BTreeMap::new();
    let mut begun = false;
    loop {
        let msg = match rx.pop() {
            Ok(m) => m,
            Err(_) if rx.is_abandoned() && rx.is_empty() => break,
            Err(_) => {
                std::thread::park_timeout(NAP);
                continue;
            }
        };
        match msg {
            WriterMsg::Begin(epoch_ns) => {
                if let (Some(w), false) = (w.as_mut(), begun) {
                    write_run(w, run_metadata, Some(epoch_ns)).map_err(err)?;
                }
                begun = true;
            }
            WriterMsg::Message(m) => {
                let header = mcap::records::MessageHeader {
                    channel_id: m.topic.channel_id(),
                    sequence: m.sequence,
                    log_time: m.log_time,
                    publish_time: m.publish_time,
                };
                if let Some(w) = w.as_mut() {
                    w.write_to_known_channel(&header, &m.buf).map_err(err)?;
                }
                if let Some(live) = live {
                    live.offer(m.topic, m.log_time, &m.buf);
                }
                stats.messages += 1;
                stats.bytes += m.buf.len() as u64;
                // Each pool ring has room for all of its buffers.
                let _ = pools[m.large as usize].push(m.buf);
                recorder.unpark();
            }
            WriterMsg::Finish(meta) => {
                summary = meta;
                break;
            }
        }
    }
    // Reached on Finish, or when the sender went away (error paths): close
    // the file properly either way.
    let Some(w) = w else {
        return Ok(stats);
    };
    // A run that ended before its first frame: its configuration still.
    if !begun {
        write_run(w, run_metadata, None).map_err(err)?;
    }
    if !summary.is_empty() {
        w.write_metadata(&mcap::records::Metadata {
            name: "speleo.summary".into(),
            metadata: summary,
        })
        .map_err(err)?;
    }
    w.finish().map_err(err)?;
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::SeekFrom;

    /// A file in memory that notes every write landing before its end.
    #[derive(Default)]
    struct AppendCheck {
        bytes: Vec<u8>,
        pos: usize,
        rewrites: usize,
    }

    impl Write for AppendCheck {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            if self.pos < self.bytes.len() {
                self.rewrites += 1;
                self.bytes.truncate(self.pos);
            }
            self.bytes.extend_from_slice(b);
            self.pos = self.bytes.len();
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Seek for AppendCheck {
        fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
            self.pos = match to {
                SeekFrom::Start(p) => p as usize,
                SeekFrom::End(d) => (self.bytes.len() as i64 + d) as usize,
                SeekFrom::Current(d) => (self.pos as i64 + d) as usize,
            };
            Ok(self.pos as u64)
        }
    }

    /// A recording of a few chunks of incompressible output messages.
    fn record(chunk_size: u64) -> AppendCheck {
        let opts = WriterOptions {
            path: Some(PathBuf::from("memory.mcap")),
            live: None,
            zstd: true,
            chunk_size,
            pool: 1,
            large_pool: 0,
            large_capacity: 0,
            run_metadata: BTreeMap::from([("mode".to_string(), "sim".to_string())]),
        };
        let mut w = start(AppendCheck::default(), Path::new("memory.mcap"), &opts).expect("start");
        write_run(&mut w, &opts.run_metadata, Some(0)).expect("run metadata");
        let mut x: u32 = 0x2545_F491;
        for seq in 0..200u32 {
            let data: Vec<u8> = (0..300)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 17;
                    x ^= x << 5;
                    x as u8
                })
                .collect();
            let header = mcap::records::MessageHeader {
                channel_id: Topic::Imu.channel_id(),
                sequence: seq,
                log_time: seq as u64,
                publish_time: seq as u64,
            };
            w.write_to_known_channel(&header, &data).expect("write");
        }
        w.finish().expect("finish");
        w.into_inner()
    }

    #[test]
    fn the_file_only_ever_grows_at_its_end() {
        // A chunk patched in place after its data can be caught half
        // patched by a kill; appended whole, it is there or cut short.
        let file = record(8 * 1024);
        assert_eq!(file.rewrites, 0);
    }

    #[test]
    fn every_cut_of_a_recording_is_read_as_a_cut_never_as_damage() {
        use super::super::read::{parse, ReadError};
        let file = record(8 * 1024).bytes;
        let whole = parse(&file, "whole").expect("whole file");
        assert_eq!(whole.messages, 200);
        assert!(whole.truncated.is_none());
        let mut last = 0;
        for cut in (8..file.len()).step_by(61) {
            match parse(&file[..cut], "cut") {
                Ok(r) => {
                    assert!(r.truncated.is_some(), "cut at {cut}");
                    assert!(r.messages >= last, "cut at {cut}: fewer messages");
                    last = r.messages;
                }
                Err(ReadError::NothingRecorded { .. }) => assert_eq!(last, 0, "cut at {cut}"),
                Err(e) => panic!("cut at {cut} of {}: {e}", file.len()),
            }
        }
        assert!(last > 0, "{last}");
    }

    /// A recorder begun at `epoch_ns` (Unix ns) with one message at mission
    /// time `at_ns`, read back.
    fn begun_at(epoch_ns: Option<u64>, at_ns: u64) -> super::super::read::Recording {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("a.mcap");
        let h = spawn(WriterOptions {
            path: Some(path.clone()),
            live: None,
            zstd: false,
            chunk_size: 4096,
            pool: 2,
            large_pool: 0,
            large_capacity: 0,
            run_metadata: BTreeMap::from([("mode".to_string(), "run".to_string())]),
        })
        .expect("writer");
        let thread = h.thread.thread().clone();
        let mut tap = super::super::tap::RecorderTap::new(None, 0).with_writer(
            h.tx,
            h.pool,
            h.large_pool,
            thread,
            true,
        );
        if let Some(e) = epoch_ns {
            tap.begin(e);
            // Only the first time base counts.
            tap.begin(e + 1);
        }
        tap.raw(Topic::RawImu, "imu", 0, at_ns, at_ns, &[0xFA, 0xFF]);
        tap.finish(BTreeMap::new());
        h.thread.join().expect("joined").expect("written");
        super::super::read::load(&path).expect("read back")
    }

    #[test]
    fn the_time_base_is_the_one_the_recording_began_with() {
        let epoch = 1_767_225_600_000_000_000;
        let r = begun_at(Some(epoch), 250_000_000);
        assert_eq!(
            r.run.get("epoch_ns").map(String::as_str),
            Some("1767225600000000000")
        );
        assert_eq!(r.epoch_ns(), epoch);
        assert_eq!(r.run.get("mode").map(String::as_str), Some("run"));
        // Receive times come back relative to the time base.
        assert_eq!(
            r.inputs.first().map(|i| i.receive_time_ns),
            Some(250_000_000)
        );
    }

    #[test]
    fn a_recording_that_never_began_keeps_its_configuration() {
        let r = begun_at(None, 0);
        assert_eq!(r.run.get("mode").map(String::as_str), Some("run"));
        assert!(!r.run.contains_key("epoch_ns"));
    }
}
