//! `speleo info`: what a recording holds, as `ros2 bag info` tells it:
//! its span, each topic with its type, encodings, count and rate, its
//! chunks and their compression, whether its summary and index are there
//! or the file was cut short, and the run that wrote it.
//!
//! A finished file is read from its summary section (a few reads, whatever
//! its size); a file without one (its writer was killed) is read from
//! start to end, chunks decompressed, up to where it breaks off.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader};
use serde::Serialize;

use crate::Error;

/// One topic of a recording.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TopicInfo {
    pub topic: String,
    /// The schema's name (a ROS 2 or Foxglove type); empty without one.
    pub message_type: String,
    pub schema_encoding: String,
    pub message_encoding: String,
    pub messages: u64,
    /// Messages over the recording's span, Hz.
    pub rate_hz: f64,
}

/// What `speleo info` tells of a recording.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RecordingInfo {
    pub bytes: u64,
    /// The MCAP header's profile (`ros2`, or empty) and writing library.
    pub profile: String,
    pub library: String,
    /// Log times of the first and last message, ns since the Unix epoch.
    pub start_ns: u64,
    pub end_ns: u64,
    pub duration_s: f64,
    pub messages: u64,
    pub topics: Vec<TopicInfo>,
    pub chunks: u64,
    /// Chunks by compression (`zstd`, `lz4`, or `none`).
    pub compression: BTreeMap<String, u64>,
    pub compressed_bytes: u64,
    pub uncompressed_bytes: u64,
    /// The summary section with its statistics is there (a finished file).
    pub summary: bool,
    /// Chunk indexes are there (readers can seek).
    pub indexed: bool,
    /// Why reading stopped before the end, for a file cut short.
    pub cut_short: Option<String>,
    /// Names of the metadata records.
    pub metadata: Vec<String>,
    /// The `speleo.run` metadata without its configuration, and the
    /// configuration itself (TOML), when the run recorded them.
    pub run: BTreeMap<String, String>,
    pub config: Option<String>,
    /// The `speleo.summary` metadata of a run that ended normally.
    pub outcome: BTreeMap<String, String>,
}

/// Read `path`'s summary, or all of it when it has none.
pub fn info(path: &Path) -> Result<RecordingInfo, Error> {
    let name = path.display();
    let mut file = File::open(path).map_err(|e| format!("cannot open {name}: {e}"))?;
    let meta = file
        .metadata()
        .map_err(|e| format!("cannot read {name}: {e}"))?;
    if meta.is_dir() {
        return Err(format!("{name}: a directory, not an MCAP recording").into());
    }
    let mut magic = [0u8; 8];
    if file.read_exact(&mut magic).is_err() || magic[..] != mcap::MAGIC[..] {
        return Err(format!(
            "{name} is not an MCAP recording (it does not begin with the MCAP magic)"
        )
        .into());
    }
    let mut out = RecordingInfo {
        bytes: meta.len(),
        ..RecordingInfo::default()
    };
    header(&mut file, &mut out).map_err(|e| format!("{name}: {e}"))?;
    match summary(&mut file).map_err(|e| format!("{name}: {e}"))? {
        Some(s) if s.stats.is_some() => {
            from_summary(&mut file, &s, &mut out).map_err(|e| format!("{name}: {e}"))?
        }
        _ => scan(&mut file, &mut out).map_err(|e| format!("{name}: {e}"))?,
    }
    out.duration_s = out.end_ns.saturating_sub(out.start_ns) as f64 * 1e-9;
    for t in &mut out.topics {
        t.rate_hz = if out.duration_s > 0.0 {
            t.messages as f64 / out.duration_s
        } else {
            0.0
        };
    }
    Ok(out)
}

/// The header record right after the magic: profile and library.
fn header(file: &mut File, out: &mut RecordingInfo) -> Result<(), String> {
    let mut head = [0u8; 9];
    file.seek(SeekFrom::Start(8)).map_err(|e| e.to_string())?;
    file.read_exact(&mut head)
        .map_err(|_| "ends before its header record".to_string())?;
    let len = u64::from_le_bytes(head[1..9].try_into().unwrap_or([0; 8]));
    if len > 1 << 20 {
        return Err(format!("a header record of {len} bytes"));
    }
    let mut body = vec![0u8; len as usize];
    file.read_exact(&mut body)
        .map_err(|_| "ends inside its header record".to_string())?;
    match mcap::parse_record(head[0], &body) {
        Ok(Record::Header(h)) => {
            out.profile = h.profile;
            out.library = h.library;
            Ok(())
        }
        Ok(_) => Err("its first record is not a header".into()),
        Err(e) => Err(format!("its header record is malformed: {e}")),
    }
}

/// The summary section, if the file has a footer that points to one.
fn summary(file: &mut File) -> Result<Option<mcap::Summary>, String> {
    let mut reader = SummaryReader::new();
    while let Some(event) = reader.next_event() {
        match event {
            Ok(SummaryReadEvent::ReadRequest(need)) => {
                let n = file.read(reader.insert(need)).map_err(|e| e.to_string())?;
                reader.notify_read(n);
            }
            Ok(SummaryReadEvent::SeekRequest(to)) => {
                let at = file.seek(to).map_err(|e| e.to_string())?;
                reader.notify_seeked(at);
            }
            // No footer where one should be: a file cut short, read whole.
            Err(_) => return Ok(None),
        }
    }
    Ok(reader.finish())
}

/// The figures from a finished file's summary section.
fn from_summary(file: &mut File, s: &mcap::Summary, out: &mut RecordingInfo) -> Result<(), String> {
    out.summary = true;
    out.indexed = !s.chunk_indexes.is_empty();
    if let Some(st) = &s.stats {
        out.messages = st.message_count;
        out.start_ns = st.message_start_time;
        out.end_ns = st.message_end_time;
        out.chunks = u64::from(st.chunk_count);
        let mut channels: Vec<_> = s.channels.values().collect();
        channels.sort_by_key(|c| c.id);
        for c in channels {
            out.topics.push(TopicInfo {
                topic: c.topic.clone(),
                message_type: c.schema.as_ref().map_or(String::new(), |s| s.name.clone()),
                schema_encoding: c
                    .schema
                    .as_ref()
                    .map_or(String::new(), |s| s.encoding.clone()),
                message_encoding: c.message_encoding.clone(),
                messages: st.channel_message_counts.get(&c.id).copied().unwrap_or(0),
                rate_hz: 0.0,
            });
        }
    }
    for ci in &s.chunk_indexes {
        *out.compression
            .entry(compression_name(&ci.compression))
            .or_default() += 1;
        out.compressed_bytes += ci.compressed_size;
        out.uncompressed_bytes += ci.uncompressed_size;
    }
    for mi in &s.metadata_indexes {
        if mi.length > 64 << 20 {
            return Err(format!("metadata {} of {} bytes", mi.name, mi.length));
        }
        let mut buf = vec![0u8; mi.length as usize];
        file.seek(SeekFrom::Start(mi.offset))
            .and_then(|_| file.read_exact(&mut buf))
            .map_err(|e| format!("metadata {}: {e}", mi.name))?;
        if buf.len() < 9 {
            return Err(format!(
                "metadata {}: a record of {} bytes",
                mi.name,
                buf.len()
            ));
        }
        match mcap::parse_record(buf[0], &buf[9..]) {
            Ok(Record::Metadata(m)) => metadata(m, out),
            _ => return Err(format!("metadata {}: not a metadata record", mi.name)),
        }
    }
    Ok(())
}

/// Everything read from start to end, for a file without a summary.
fn scan(file: &mut File, out: &mut RecordingInfo) -> Result<(), String> {
    file.seek(SeekFrom::Start(0)).map_err(|e| e.to_string())?;
    let mut reader =
        LinearReader::new_with_options(LinearReaderOptions::default().with_emit_chunks(true));
    let mut schemas: BTreeMap<u16, (String, String)> = BTreeMap::new();
    let mut channels: BTreeMap<u16, TopicInfo> = BTreeMap::new();
    let mut read = 0u64;
    let (mut first, mut last) = (u64::MAX, 0u64);
    while let Some(event) = reader.next_event() {
        let (opcode, data) = match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let n = file.read(reader.insert(need)).map_err(|e| e.to_string())?;
                reader.notify_read(n);
                read += n as u64;
                continue;
            }
            Ok(LinearReadEvent::Record { opcode, data }) => (opcode, data),
            Err(e) => {
                out.cut_short = Some(format!("breaks off after {read} bytes ({e})"));
                break;
            }
        };
        let record = match mcap::parse_record(opcode, data) {
            Ok(r) => r,
            Err(e) => {
                out.cut_short = Some(format!("a malformed record after {read} bytes ({e})"));
                break;
            }
        };
        let mut inner: Vec<Record<'static>> = Vec::new();
        match record {
            Record::Chunk { header, data } => {
                out.chunks += 1;
                *out.compression
                    .entry(compression_name(&header.compression))
                    .or_default() += 1;
                out.compressed_bytes += header.compressed_size;
                out.uncompressed_bytes += header.uncompressed_size;
                let chunk = mcap::read::ChunkReader::new(header, &data)
                    .map_err(|e| format!("chunk {}: {e}", out.chunks))?;
                for r in chunk {
                    inner.push(
                        r.map_err(|e| format!("chunk {}: {e}", out.chunks))?
                            .into_owned(),
                    );
                }
            }
            Record::ChunkIndex(_) => out.indexed = true,
            Record::Statistics(_) => out.summary = true,
            other => inner.push(other.into_owned()),
        }
        for r in inner {
            match r {
                Record::Schema { header, .. } => {
                    schemas.insert(header.id, (header.name, header.encoding));
                }
                Record::Channel(c) => {
                    let (name, encoding) = schemas.get(&c.schema_id).cloned().unwrap_or_default();
                    channels.entry(c.id).or_insert(TopicInfo {
                        topic: c.topic,
                        message_type: name,
                        schema_encoding: encoding,
                        message_encoding: c.message_encoding,
                        ..TopicInfo::default()
                    });
                }
                Record::Message { header, .. } => {
                    out.messages += 1;
                    first = first.min(header.log_time);
                    last = last.max(header.log_time);
                    if let Some(t) = channels.get_mut(&header.channel_id) {
                        t.messages += 1;
                    }
                }
                Record::Metadata(m) => metadata(m, out),
                _ => {}
            }
        }
    }
    if out.messages > 0 {
        out.start_ns = first;
        out.end_ns = last;
    }
    out.topics = channels.into_values().collect();
    Ok(())
}

fn metadata(m: mcap::records::Metadata, out: &mut RecordingInfo) {
    match m.name.as_str() {
        "speleo.run" => {
            let mut run = m.metadata.clone();
            out.config = run.remove("config");
            out.run = run;
        }
        "speleo.summary" => out.outcome = m.metadata.clone(),
        _ => {}
    }
    out.metadata.push(m.name);
}

fn compression_name(c: &str) -> String {
    if c.is_empty() {
        "none".into()
    } else {
        c.into()
    }
}

/// `ns` since the Unix epoch as UTC, to the millisecond.
pub fn utc(ns: u64) -> String {
    let s = ns / 1_000_000_000;
    let ms = (ns / 1_000_000) % 1000;
    let (days, rem) = ((s / 86_400) as i64, s % 86_400);
    // Days to a civil date (H. Hinnant's algorithm, proleptic Gregorian).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{ms:03}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

fn size(bytes: u64) -> String {
    match bytes {
        b if b >= 1 << 30 => format!("{:.2} GiB", b as f64 / (1u64 << 30) as f64),
        b if b >= 1 << 20 => format!("{:.1} MiB", b as f64 / (1u64 << 20) as f64),
        b if b >= 1 << 10 => format!("{:.1} KiB", b as f64 / 1024.0),
        b => format!("{b} B"),
    }
}

impl std::fmt::Display for RecordingInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "size:        {}", size(self.bytes))?;
        writeln!(
            f,
            "profile:     {} (written by {})",
            if self.profile.is_empty() {
                "none"
            } else {
                &self.profile
            },
            if self.library.is_empty() {
                "?"
            } else {
                &self.library
            }
        )?;
        writeln!(f, "duration:    {:.3} s", self.duration_s)?;
        if self.messages > 0 {
            writeln!(f, "start:       {}", utc(self.start_ns))?;
            writeln!(f, "end:         {}", utc(self.end_ns))?;
        }
        writeln!(f, "messages:    {}", self.messages)?;
        let kinds: Vec<String> = self
            .compression
            .iter()
            .map(|(k, n)| format!("{k}: {n}"))
            .collect();
        writeln!(
            f,
            "chunks:      {} ({}), {} compressed from {}",
            self.chunks,
            kinds.join(", "),
            size(self.compressed_bytes),
            size(self.uncompressed_bytes)
        )?;
        match &self.cut_short {
            Some(why) => writeln!(
                f,
                "finished:    no: no summary or index, the file {why} (its writer was stopped?); read to there"
            )?,
            None => writeln!(
                f,
                "finished:    {}",
                match (self.summary, self.indexed) {
                    (true, true) => "yes: summary and chunk index present",
                    (true, false) => "summary present, no chunk index",
                    (false, _) => "no summary section",
                }
            )?,
        }
        if !self.metadata.is_empty() {
            writeln!(f, "metadata:    {}", self.metadata.join(", "))?;
        }
        if !self.run.is_empty() {
            let run: Vec<String> = self.run.iter().map(|(k, v)| format!("{k} {v}")).collect();
            writeln!(f, "run:         {}", run.join(", "))?;
        }
        if let Some(c) = &self.config {
            writeln!(
                f,
                "config:      {} lines of TOML (`--config` prints them)",
                c.lines().count()
            )?;
        }
        if !self.outcome.is_empty() {
            let o: Vec<String> = self
                .outcome
                .iter()
                .map(|(k, v)| format!("{k} {v}"))
                .collect();
            writeln!(f, "outcome:     {}", o.join(", "))?;
        }
        writeln!(f, "topics:      {}", self.topics.len())?;
        let width = self.topics.iter().map(|t| t.topic.len()).max().unwrap_or(0);
        let tw = self
            .topics
            .iter()
            .map(|t| t.message_type.len())
            .max()
            .unwrap_or(0);
        for t in &self.topics {
            writeln!(
                f,
                "  {:width$}  {:tw$}  {:>9} msgs  {:>8.2} Hz  ({}, schema {})",
                t.topic,
                t.message_type,
                t.messages,
                t.rate_hz,
                t.message_encoding,
                if t.schema_encoding.is_empty() {
                    "none"
                } else {
                    &t.schema_encoding
                }
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::utc;

    #[test]
    fn utc_dates_match_the_calendar() {
        assert_eq!(utc(0), "1970-01-01T00:00:00.000Z");
        // 2000-02-29 12:34:56.789 (a leap day in a century leap year).
        assert_eq!(utc(951_827_696_789_000_000), "2000-02-29T12:34:56.789Z");
        assert_eq!(utc(1_796_083_200_000_000_000), "2026-12-01T00:00:00.000Z");
    }
}
