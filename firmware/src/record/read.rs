//! Loading a recording for replay. A file whose writer was killed has no
//! summary and ends inside a record: everything up to the last complete chunk
//! is used. A file that is damaged (a bad chunk CRC, a malformed record) is
//! refused with the place where it broke.

use std::collections::BTreeMap;
use std::path::Path;

use speleo_hal::replay::RecordedInput;
use speleo_hal::Device;
use thiserror::Error;

use super::compare::ExpectedMessage;
use super::topics::{Role, Topic};

#[derive(Debug, Error)]
pub enum ReadError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path} is not an MCAP recording: {why}")]
    NotMcap { path: String, why: String },
    #[error("{path} is damaged after {messages} messages: {why}")]
    Damaged {
        path: String,
        messages: u64,
        why: String,
    },
    #[error("{path}: message {sequence} on {topic} is malformed: {why}")]
    BadMessage {
        path: String,
        topic: &'static str,
        sequence: u32,
        why: String,
    },
    #[error("{path} was not written by speleo (no speleo.run metadata)")]
    NotSpeleo { path: String },
    #[error(
        "{path} ends before its first chunk (its process was stopped at once?): nothing to replay"
    )]
    NothingRecorded { path: String },
}

pub struct Recording {
    /// The `speleo.run` metadata: config, mode, epoch.
    pub run: BTreeMap<String, String>,
    /// The `speleo.summary` metadata, present when the run ended normally.
    pub summary: Option<BTreeMap<String, String>>,
    pub inputs: Vec<RecordedInput>,
    /// The executive's slips and overruns, when it ran in real time.
    pub timing: Vec<crate::record::frame_timing::FrameTiming>,
    /// Outputs by topic (index = `Topic as usize`).
    pub expected: Vec<Vec<ExpectedMessage>>,
    pub messages: u64,
    /// Highest frame number seen in any message.
    pub max_frame: Option<u64>,
    /// Why reading stopped early (a killed writer), if it did.
    pub truncated: Option<String>,
}

impl Recording {
    pub fn epoch_ns(&self) -> u64 {
        self.run
            .get("epoch_ns")
            .and_then(|s| s.parse().ok())
            .unwrap_or(0)
    }

    /// Frames the recorded run executed, when it ended normally.
    pub fn frames(&self) -> Option<u64> {
        self.summary
            .as_ref()
            .and_then(|s| s.get("frames"))
            .and_then(|s| s.parse().ok())
    }

    /// The last frame whose messages are all in the file.
    pub fn last_complete_frame(&self) -> Option<u64> {
        match self.frames() {
            // Frame numbers run past the count when the clock jumped.
            Some(n) => n.checked_sub(1).max(self.max_frame),
            // The last frame seen may be cut by the lost chunk.
            None => self.max_frame.and_then(|f| f.checked_sub(1)),
        }
    }
}

/// The top-level records of an MCAP file: (opcode, offset, total length).
pub struct RecordScan {
    pub records: Vec<(u8, usize, usize)>,
    /// Bytes up to the end of the last record that is wholly in the file.
    pub complete_len: usize,
}

/// Walk the top-level records (`opcode: u8, length: u64 LE, body`) after the
/// magic. A killed writer leaves a last record (usually a chunk) whose
/// declared length runs past the end of the file; everything before it is
/// whole.
pub fn scan_records(bytes: &[u8]) -> RecordScan {
    let magic = mcap::MAGIC.len();
    let mut at = magic.min(bytes.len());
    let mut records = Vec::new();
    while at + 9 <= bytes.len() {
        let op = bytes[at];
        let mut len = [0u8; 8];
        len.copy_from_slice(&bytes[at + 1..at + 9]);
        let body = u64::from_le_bytes(len);
        let Some(end) = (at as u64 + 9)
            .checked_add(body)
            .filter(|e| *e <= bytes.len() as u64)
        else {
            break;
        };
        records.push((op, at, end as usize - at));
        at = end as usize;
        // The footer is followed only by the closing magic.
        if op == 0x02 {
            break;
        }
    }
    RecordScan {
        records,
        complete_len: at,
    }
}

pub fn load(path: &Path) -> Result<Recording, ReadError> {
    let p = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| ReadError::Io {
        path: p.clone(),
        source,
    })?;
    parse(&bytes, &p)
}

/// A recording's bytes, as [`load`] reads them; `p` names it in errors.
pub fn parse(bytes: &[u8], p: &str) -> Result<Recording, ReadError> {
    let p = p.to_string();
    if bytes.len() < 8 || &bytes[..8] != mcap::MAGIC {
        return Err(ReadError::NotMcap {
            path: p,
            why: "it does not start with the MCAP magic".into(),
        });
    }
    // Read only the records that are wholly in the file; a cut tail means the
    // writer was killed, and any error inside the whole records is damage.
    let scan = scan_records(bytes);
    let finished = scan.records.last().is_some_and(|r| r.0 == 0x02);
    let cut = bytes.len() - scan.complete_len;
    let whole = &bytes[..scan.complete_len];
    let records = super::flatten::Flattened::new(whole, true, true);
    let mut rec = Recording {
        run: BTreeMap::new(),
        summary: None,
        inputs: Vec::new(),
        timing: Vec::new(),
        expected: vec![Vec::new(); Topic::ALL.len()],
        messages: 0,
        max_frame: None,
        truncated: (!finished).then(|| {
            if cut > 0 {
                format!("the writer stopped inside a record; the last {cut} bytes are an unfinished chunk")
            } else {
                "the writer stopped before closing the file".to_string()
            }
        }),
    };
    let mut channels: BTreeMap<u16, Topic> = BTreeMap::new();
    let epoch = |run: &BTreeMap<String, String>| -> u64 {
        run.get("epoch_ns")
            .and_then(|s| s.parse().ok())
            .unwrap_or(0)
    };
    for r in records {
        let r = match r {
            Ok(r) => r,
            // The whole records of an unfinished file end without a data-end
            // record; that is the expected end, not damage.
            Err(mcap::McapError::UnexpectedEof) if !finished => break,
            Err(e) => {
                return Err(ReadError::Damaged {
                    path: p,
                    messages: rec.messages,
                    why: e.to_string(),
                })
            }
        };
        match r {
            mcap::records::Record::Channel(c) => {
                if let Some(t) = Topic::by_name(&c.topic) {
                    channels.insert(c.id, t);
                }
            }
            mcap::records::Record::Metadata(m) if m.name == "speleo.run" => rec.run = m.metadata,
            mcap::records::Record::Metadata(m) if m.name == "speleo.summary" => {
                rec.summary = Some(m.metadata)
            }
            mcap::records::Record::Message { header, data } => {
                rec.messages += 1;
                let Some(&topic) = channels.get(&header.channel_id) else {
                    continue;
                };
                let frame = header.sequence as u64;
                rec.max_frame = Some(rec.max_frame.map_or(frame, |m| m.max(frame)));
                let info = topic.info();
                match info.role {
                    Role::Output => rec.expected[topic as usize].push(ExpectedMessage {
                        frame,
                        data: data.into_owned(),
                    }),
                    Role::Input => {
                        let bad = |why: String| ReadError::BadMessage {
                            path: p.clone(),
                            topic: info.name,
                            sequence: header.sequence,
                            why,
                        };
                        let raw = super::cdr::read_raw_input(&data)
                            .map_err(|e| bad(format!("not a CDR RawInput: {e}")))?;
                        let device = Device::from_name(raw.device)
                            .ok_or_else(|| bad(format!("unknown device \"{}\"", raw.device)))?;
                        rec.inputs.push(RecordedInput {
                            frame,
                            device,
                            receive_time_ns: header.publish_time.saturating_sub(epoch(&rec.run)),
                            bytes: raw.data.to_vec(),
                        });
                    }
                    Role::Schedule => {
                        let t = crate::record::frame_timing::read(frame, &data).map_err(|why| {
                            ReadError::BadMessage {
                                path: p.clone(),
                                topic: info.name,
                                sequence: header.sequence,
                                why,
                            }
                        })?;
                        rec.timing.push(t);
                    }
                    Role::Telemetry | Role::Sim => {}
                }
            }
            _ => {}
        }
    }
    if rec.run.is_empty() {
        // The run's metadata goes out with the first chunk: a file cut
        // short before it holds nothing.
        if rec.truncated.is_some() {
            return Err(ReadError::NothingRecorded { path: p });
        }
        return Err(ReadError::NotSpeleo { path: p });
    }
    Ok(rec)
}
