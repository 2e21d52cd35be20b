//! The recorder's tap: serialises each message into a pooled buffer, folds
//! outputs into the run's output hash, compares them with a recording during
//! replay, and hands the buffer to the writer thread.

use std::collections::BTreeMap;
use std::thread::Thread;

use xxhash_rust::xxh3::Xxh3Default;

use super::compare::Comparer;
use super::encode::{Bounded, Time};
use super::topics::{Role, Topic};
use super::writer::{Outgoing, WriterMsg, MESSAGE_CAPACITY, NAP};

struct TapWriter {
    tx: rtrb::Producer<WriterMsg>,
    pool: rtrb::Consumer<Vec<u8>>,
    large_pool: rtrb::Consumer<Vec<u8>>,
    thread: Thread,
    /// Wait for a free buffer (virtual time: nothing is ever dropped) or drop
    /// and count (real time: the frame must not wait for the disk).
    blocking: bool,
}

/// Counters of the recorder.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TapCounters {
    /// Output messages produced (all hashed).
    pub outputs: u64,
    /// Messages handed to the writer.
    pub written: u64,
    /// Messages not written because no buffer was free (real time only).
    pub dropped_no_buffer: u64,
    /// Messages larger than a buffer: not written and not hashed.
    pub too_large: u64,
    /// The writer thread ended early (disk full, I/O error).
    pub writer_gone: bool,
}

pub struct RecorderTap {
    epoch_ns: u64,
    /// The time base is set ([`RecorderTap::begin`]).
    begun: bool,
    writer: Option<TapWriter>,
    local: Vec<u8>,
    local_large: Vec<u8>,
    /// Pooled buffers (small, large) kept back after a refused message.
    spare: [Option<Vec<u8>>; 2],
    hasher: Xxh3Default,
    /// Over every raw input: the device byte streams as received.
    input_hasher: Xxh3Default,
    pub counters: TapCounters,
    compare: Option<Comparer>,
}

impl RecorderTap {
    /// A tap without its time base yet ([`RecorderTap::begin`]);
    /// `large_capacity` is the size of a point-cloud message.
    pub fn new(compare: Option<Comparer>, large_capacity: usize) -> Self {
        RecorderTap {
            epoch_ns: 0,
            begun: false,
            writer: None,
            local: Vec::with_capacity(MESSAGE_CAPACITY),
            local_large: Vec::with_capacity(large_capacity),
            spare: [None, None],
            hasher: Xxh3Default::new(),
            input_hasher: Xxh3Default::new(),
            counters: TapCounters::default(),
            compare,
        }
    }

    /// Send messages to the writer thread `thread` through `tx`, taking
    /// buffers from `pool`.
    pub fn with_writer(
        mut self,
        tx: rtrb::Producer<WriterMsg>,
        pool: rtrb::Consumer<Vec<u8>>,
        large_pool: rtrb::Consumer<Vec<u8>>,
        thread: Thread,
        blocking: bool,
    ) -> Self {
        self.writer = Some(TapWriter {
            tx,
            pool,
            large_pool,
            thread,
            blocking,
        });
        self
    }

    /// Mission time 0 is `epoch_ns` (Unix ns): added to every time so
    /// recordings carry Unix times, and written with the run's metadata.
    /// Only the first call counts.
    pub fn begin(&mut self, epoch_ns: u64) {
        if self.begun {
            return;
        }
        self.begun = true;
        self.epoch_ns = epoch_ns;
        if let Some(w) = self.writer.as_mut() {
            // The ring has a slot for it beside every buffer's.
            if w.tx.push(WriterMsg::Begin(epoch_ns)).is_err() {
                self.counters.writer_gone = true;
            }
            w.thread.unpark();
        }
    }

    /// Whether [`RecorderTap::begin`] has set the time base.
    pub fn has_begun(&self) -> bool {
        self.begun
    }

    pub fn epoch_ns(&self) -> u64 {
        self.epoch_ns
    }

    /// A time relative to start as a Unix time.
    pub fn time(&self, ns: u64) -> Time {
        Time::from_ns(self.epoch_ns + ns)
    }

    /// Record one message. `log_ns` is the frame time, `publish_ns` the time
    /// of validity of the data, both relative to start; `body` writes the
    /// message (CDR).
    pub fn emit(
        &mut self,
        topic: Topic,
        frame: u64,
        log_ns: u64,
        publish_ns: u64,
        body: impl FnOnce(&mut Bounded<'_>) -> std::io::Result<()>,
    ) {
        self.emit_sized(topic, frame, log_ns, publish_ns, false, body);
    }

    /// Record one message in a buffer of the large pool (point clouds).
    pub fn emit_large(
        &mut self,
        topic: Topic,
        frame: u64,
        log_ns: u64,
        publish_ns: u64,
        body: impl FnOnce(&mut Bounded<'_>) -> std::io::Result<()>,
    ) {
        self.emit_sized(topic, frame, log_ns, publish_ns, true, body);
    }

    fn emit_sized(
        &mut self,
        topic: Topic,
        frame: u64,
        log_ns: u64,
        publish_ns: u64,
        large: bool,
        body: impl FnOnce(&mut Bounded<'_>) -> std::io::Result<()>,
    ) {
        let (mut buf, pooled) = self.take_buffer(large);
        buf.clear();
        if body(&mut Bounded(&mut buf)).is_err() {
            self.counters.too_large += 1;
            self.put_back(buf, pooled, large);
            return;
        }
        let log_time = self.epoch_ns + log_ns;
        let publish_time = self.epoch_ns + publish_ns;
        if topic.info().role == Role::Output {
            self.counters.outputs += 1;
            self.hasher.update(&topic.channel_id().to_le_bytes());
            self.hasher.update(&frame.to_le_bytes());
            self.hasher.update(&log_time.to_le_bytes());
            self.hasher.update(&publish_time.to_le_bytes());
            self.hasher.update(&(buf.len() as u64).to_le_bytes());
            self.hasher.update(&buf);
            if let Some(c) = self.compare.as_mut() {
                c.check(topic, frame, &buf);
            }
        } else if topic.info().role == Role::Input {
            self.input_hasher.update(&topic.channel_id().to_le_bytes());
            self.input_hasher.update(&(buf.len() as u64).to_le_bytes());
            self.input_hasher.update(&buf);
        }
        if !pooled {
            self.put_back(buf, false, large);
            return;
        }
        let m = Outgoing {
            topic,
            large,
            sequence: frame as u32,
            log_time,
            publish_time,
            buf,
        };
        if let Some(w) = self.writer.as_mut() {
            // Never full: the ring has a slot for every buffer of the pool.
            match w.tx.push(WriterMsg::Message(m)) {
                Ok(()) => {
                    self.counters.written += 1;
                    w.thread.unpark();
                }
                Err(_) => self.counters.writer_gone = true,
            }
        }
    }

    /// Record one raw input (CDR `RawInput`: the bytes as they are).
    pub fn raw(
        &mut self,
        topic: Topic,
        device: &'static str,
        frame: u64,
        frame_ns: u64,
        receive_ns: u64,
        bytes: &[u8],
    ) {
        let t = self.time(receive_ns);
        self.emit_sized(topic, frame, frame_ns, receive_ns, false, |w| {
            super::cdr::write_raw_input(w, t.sec, t.nsec, device, bytes)
        });
    }

    /// A buffer for the next message, and whether it goes to the writer.
    fn take_buffer(&mut self, large: bool) -> (Vec<u8>, bool) {
        if let Some(b) = self.spare[large as usize].take() {
            return (b, true);
        }
        let mut got = None;
        if let Some(w) = self.writer.as_mut() {
            let pool = if large {
                &mut w.large_pool
            } else {
                &mut w.pool
            };
            while !self.counters.writer_gone {
                match pool.pop() {
                    Ok(b) => {
                        got = Some(b);
                        break;
                    }
                    Err(_) if pool.is_abandoned() => self.counters.writer_gone = true,
                    Err(_) if w.blocking => {
                        // Virtual time: wait for the disk rather than lose data.
                        w.thread.unpark();
                        std::thread::park_timeout(NAP);
                    }
                    Err(_) => {
                        self.counters.dropped_no_buffer += 1;
                        break;
                    }
                }
            }
        }
        match got {
            Some(b) => (b, true),
            // Not recorded, but still hashed and compared.
            None if large => (std::mem::take(&mut self.local_large), false),
            None => (std::mem::take(&mut self.local), false),
        }
    }

    fn put_back(&mut self, buf: Vec<u8>, pooled: bool, large: bool) {
        if pooled {
            self.spare[large as usize] = Some(buf);
        } else if large {
            self.local_large = buf;
        } else {
            self.local = buf;
        }
    }

    /// Hash of every raw input recorded (device, receive time and bytes).
    pub fn input_hash(&self) -> u64 {
        self.input_hasher.digest()
    }

    /// Hash over every output message so far, in order.
    pub fn output_hash(&self) -> u64 {
        self.hasher.digest()
    }

    pub fn comparer(&self) -> Option<&Comparer> {
        self.compare.as_ref()
    }

    pub fn comparer_mut(&mut self) -> Option<&mut Comparer> {
        self.compare.as_mut()
    }

    /// Close the recording with a summary record; the writer thread then
    /// finishes the file and ends.
    pub fn finish(&mut self, summary: BTreeMap<String, String>) {
        if let Some(mut w) = self.writer.take() {
            let _ = w.tx.push(WriterMsg::Finish(summary));
            w.thread.unpark();
        }
    }
}
