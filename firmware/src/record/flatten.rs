//! Every record of an MCAP file in order, chunks unpacked, as the mcap
//! crate's `ChunkFlattener` gives them, but with a limit on record
//! lengths (the crate's flattener has none, and a record claiming nearly
//! 2^64 bytes overflows its arithmetic) and the declared lengths of each
//! record's fields checked before it is parsed (see `length_check`). Both
//! were found by the `mcap_recording` fuzz target.

use mcap::records::Record;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::{McapError, McapResult};

/// No record we write is longer than this (chunks are at most 1 GiB).
const MIN_RECORD_LIMIT: usize = 1 << 30;

/// Stops after the first error (the reader would repeat it).
pub struct Flattened<'a> {
    buf: &'a [u8],
    reader: LinearReader,
    failed: bool,
    /// A chunk whose records run past its end: the reader is given the
    /// file up to it, and this error where it ends.
    damaged_chunk: bool,
}

impl<'a> Flattened<'a> {
    /// `skip_end_magic` for a file a killed writer left open;
    /// `validate_crcs` to check each chunk's CRC.
    pub fn new(buf: &'a [u8], skip_end_magic: bool, validate_crcs: bool) -> Self {
        let limit = buf.len().max(MIN_RECORD_LIMIT);
        let bad = super::length_check::first_bad_chunk(buf);
        Flattened {
            buf: &buf[..bad.unwrap_or(buf.len())],
            damaged_chunk: bad.is_some(),
            reader: LinearReader::new_with_options(
                LinearReaderOptions::default()
                    .with_record_length_limit(limit)
                    .with_skip_end_magic(skip_end_magic)
                    .with_validate_chunk_crcs(validate_crcs),
            ),
            failed: false,
        }
    }
}

impl Iterator for Flattened<'_> {
    type Item = McapResult<Record<'static>>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        while let Some(event) = self.reader.next_event() {
            match event {
                Ok(LinearReadEvent::ReadRequest(need)) => {
                    let n = need.min(self.buf.len());
                    self.reader.insert(n).copy_from_slice(&self.buf[..n]);
                    self.reader.notify_read(n);
                    self.buf = &self.buf[n..];
                }
                Ok(LinearReadEvent::Record { data, opcode }) => {
                    let r = if super::length_check::lengths_fit(opcode, data) {
                        mcap::parse_record(opcode, data).map(Record::into_owned)
                    } else {
                        Err(McapError::RecordTooLarge {
                            opcode,
                            len: data.len() as u64,
                        })
                    };
                    self.failed = r.is_err();
                    return Some(r);
                }
                Err(e) => {
                    self.failed = true;
                    if self.damaged_chunk && matches!(e, McapError::UnexpectedEof) {
                        return Some(Err(McapError::UnexpectedEoc));
                    }
                    return Some(Err(e));
                }
            }
        }
        self.failed = true;
        self.damaged_chunk.then_some(Err(McapError::UnexpectedEoc))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_claiming_nearly_2_64_bytes_is_an_error() {
        let mut file = mcap::MAGIC.to_vec();
        // A header record, then an uncompressed chunk whose one record
        // claims u64::MAX - 3 bytes.
        file.push(0x01);
        file.extend_from_slice(&8u64.to_le_bytes());
        file.extend_from_slice(&[0; 8]);
        let mut inner = vec![0x05];
        inner.extend_from_slice(&(u64::MAX - 3).to_le_bytes());
        let mut chunk = Vec::new();
        chunk.extend_from_slice(&[0; 16]); // start and end times
        chunk.extend_from_slice(&(inner.len() as u64).to_le_bytes());
        chunk.extend_from_slice(&0u32.to_le_bytes()); // no CRC
        chunk.extend_from_slice(&0u32.to_le_bytes()); // no compression
        chunk.extend_from_slice(&(inner.len() as u64).to_le_bytes());
        chunk.extend_from_slice(&inner);
        file.push(0x06);
        file.extend_from_slice(&(chunk.len() as u64).to_le_bytes());
        file.extend_from_slice(&chunk);
        let results: Vec<_> = Flattened::new(&file, true, true).collect();
        assert!(matches!(results.last(), Some(Err(_))), "{results:?}");
    }

    #[test]
    fn the_inputs_that_once_broke_the_reader_are_errors_and_the_seed_reads() {
        let dir =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/mcap_recording");
        let mut regressions = 0;
        for e in std::fs::read_dir(&dir).expect("the fuzz seeds") {
            let path = e.expect("entry").path();
            let bytes = std::fs::read(&path).expect("seed");
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            let read = crate::record::read::parse(&bytes, name);
            if name.starts_with("regression-") {
                regressions += 1;
                assert!(read.is_err(), "{name} reads");
            } else {
                assert!(read.is_ok(), "{name}: {:?}", read.err());
            }
        }
        assert!(regressions >= 3);
    }
}
