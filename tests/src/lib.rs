//! Helpers for Speleo's end-to-end tests.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use speleo_firmware::args::{Outputs, ReplayArgs, SimArgs};
use speleo_firmware::commands;

/// Run `speleo sim --route` in this process: the helpers drive the
/// world's route (a short, known path) rather than exploring.
pub fn sim(seed: u64, duration_s: f64, record: Option<&Path>, report: Option<&Path>) -> ExitCode {
    sim_with_config(seed, duration_s, None, record, report)
}

/// Run `speleo sim` in this process with a configuration file.
pub fn sim_with_config(
    seed: u64,
    duration_s: f64,
    config: Option<&Path>,
    record: Option<&Path>,
    report: Option<&Path>,
) -> ExitCode {
    sim_with_trajectory(seed, duration_s, config, record, report, None)
}

/// Run `speleo sim` in this process, writing SLAM's keyframe trajectory.
pub fn sim_with_trajectory(
    seed: u64,
    duration_s: f64,
    config: Option<&Path>,
    record: Option<&Path>,
    report: Option<&Path>,
    trajectory: Option<&Path>,
) -> ExitCode {
    commands::sim(
        SimArgs {
            world: None,
            start: None,
            seed: Some(seed),
            noise_seed: None,
            duration: Some(duration_s),
            config: config.map(Path::to_path_buf),
            route: true,
            trajectory: trajectory.map(Path::to_path_buf),
            faults: Vec::new(),
            dump_validations: None,
            out: Outputs {
                record: record.map(Path::to_path_buf),
                report: report.map(Path::to_path_buf),
                ..Outputs::default()
            },
        },
        false,
    )
    .unwrap_or_else(|e| panic!("sim failed: {e}"))
}

/// Run `speleo replay` in this process.
pub fn replay(log: &Path, report: Option<&Path>) -> ExitCode {
    commands::replay(
        ReplayArgs {
            log: log.to_path_buf(),
            out: Outputs {
                report: report.map(Path::to_path_buf),
                ..Outputs::default()
            },
        },
        false,
    )
    .unwrap_or_else(|e| panic!("replay failed: {e}"))
}

/// A TUM trajectory file: (time s, position) per line.
pub fn read_tum(path: &Path) -> Vec<(f64, [f64; 3])> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .map(|x| x.parse().unwrap_or_else(|e| panic!("{l}: {e}")))
                .collect();
            assert_eq!(v.len(), 8, "a TUM line has 8 numbers: {l}");
            (v[0], [v[1], v[2], v[3]])
        })
        .collect()
}

/// Reads recorded messages through their channels' `ros2msg` schemas,
/// parsing each schema once.
#[derive(Default)]
pub struct MessageDecoder {
    defs: std::collections::BTreeMap<u16, speleo_firmware::record::msg_def::MessageDefs>,
}

impl MessageDecoder {
    /// The message as JSON; panics (naming the topic) when it does not
    /// match its schema.
    pub fn decode(&mut self, m: &mcap::Message<'_>) -> serde_json::Value {
        use speleo_firmware::record::{cdr_json, msg_def::MessageDefs};
        let topic = &m.channel.topic;
        let defs = self.defs.entry(m.channel.id).or_insert_with(|| {
            let schema = m
                .channel
                .schema
                .as_ref()
                .unwrap_or_else(|| panic!("{topic} has no schema"));
            assert_eq!(schema.encoding, "ros2msg", "{topic}");
            let text = std::str::from_utf8(&schema.data).expect("schema text");
            MessageDefs::parse(&schema.name, text).unwrap_or_else(|e| panic!("{topic}: {e}"))
        });
        cdr_json::decode(defs, &m.data).unwrap_or_else(|e| panic!("{topic}: {e}"))
    }
}

pub fn read_json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

pub struct Scratch {
    pub dir: tempfile::TempDir,
}

impl Scratch {
    pub fn new() -> Self {
        Scratch {
            dir: tempfile::tempdir().unwrap_or_else(|e| panic!("tempdir: {e}")),
        }
    }
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }
}

impl Default for Scratch {
    fn default() -> Self {
        Self::new()
    }
}

/// Copy an MCAP file record by record, letting `edit` replace the data of
/// any message (topic, sequence, data). Schemas, channel ids, metadata and
/// every other message are kept as they were.
pub fn rewrite_mcap(
    src: &Path,
    dst: &Path,
    mut edit: impl FnMut(&str, u32, &[u8]) -> Option<Vec<u8>>,
) -> usize {
    let bytes = std::fs::read(src).unwrap_or_else(|e| panic!("{}: {e}", src.display()));
    let file = std::fs::File::create(dst).unwrap_or_else(|e| panic!("{}: {e}", dst.display()));
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .compression_threads(0)
        .create(std::io::BufWriter::new(file))
        .unwrap_or_else(|e| panic!("{e}"));
    let mut topics: BTreeMap<u16, String> = BTreeMap::new();
    let mut edited = 0;
    for r in mcap::read::ChunkFlattener::new(&bytes).unwrap_or_else(|e| panic!("{e}")) {
        match r.unwrap_or_else(|e| panic!("{e}")) {
            mcap::records::Record::Schema { header, data } => {
                w.add_schema_with_id(header.id, &header.name, &header.encoding, &data)
                    .unwrap_or_else(|e| panic!("{e}"));
            }
            mcap::records::Record::Channel(c) => {
                w.add_channel_with_id(
                    c.id,
                    c.schema_id,
                    &c.topic,
                    &c.message_encoding,
                    &c.metadata,
                )
                .unwrap_or_else(|e| panic!("{e}"));
                topics.insert(c.id, c.topic);
            }
            mcap::records::Record::Metadata(m) => {
                w.write_metadata(&m).unwrap_or_else(|e| panic!("{e}"));
            }
            mcap::records::Record::Message { header, data } => {
                let topic = topics.get(&header.channel_id).map_or("", String::as_str);
                let data = match edit(topic, header.sequence, &data) {
                    Some(new) => {
                        edited += 1;
                        new
                    }
                    None => data.into_owned(),
                };
                w.write_to_known_channel(&header, &data)
                    .unwrap_or_else(|e| panic!("{e}"));
            }
            _ => {}
        }
    }
    w.finish().unwrap_or_else(|e| panic!("{e}"));
    edited
}

/// Flip bit `mask` of byte `index` of a raw-input message's payload (the
/// `uint8[] data` at the end of a CDR `RawInput`).
pub fn flip_raw_byte(data: &[u8], index: usize, mask: u8) -> Vec<u8> {
    let raw = speleo_firmware::record::cdr::read_raw_input(data).unwrap_or_else(|e| panic!("{e}"));
    let start = data.len() - raw.data.len();
    let mut v = data.to_vec();
    v[start + index] ^= mask;
    v
}
