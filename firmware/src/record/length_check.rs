//! Every length a record declares for a field must fit in the record.
//!
//! The mcap crate's record parser allocates a string's or an array's
//! declared length before reading it, so a damaged record declaring 4 GB
//! makes it ask for 4 GB (found by the `mcap_recording` fuzz target). This
//! walks the length-prefixed fields of each record type (MCAP
//! specification, records section) without allocating.

/// A cursor over a record's body.
struct Fields<'a> {
    rest: &'a [u8],
}

impl<'a> Fields<'a> {
    fn take(&mut self, n: u64) -> Option<&'a [u8]> {
        let n = usize::try_from(n).ok().filter(|n| *n <= self.rest.len())?;
        let (head, tail) = self.rest.split_at(n);
        self.rest = tail;
        Some(head)
    }
    fn skip(&mut self, n: u64) -> Option<()> {
        self.take(n).map(|_| ())
    }
    fn u32(&mut self) -> Option<u64> {
        let b = self.take(4)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64)
    }
    fn u64(&mut self) -> Option<u64> {
        let b = self.take(8)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Some(u64::from_le_bytes(a))
    }
    /// A u32-prefixed string or byte array.
    fn bytes32(&mut self) -> Option<()> {
        let n = self.u32()?;
        self.skip(n)
    }
    /// A u64-prefixed byte array.
    fn bytes64(&mut self) -> Option<()> {
        let n = self.u64()?;
        self.skip(n)
    }
    /// A map or array given as its byte length, with `entry` read until it
    /// is used up.
    fn sized(&mut self, mut entry: impl FnMut(&mut Fields<'a>) -> Option<()>) -> Option<()> {
        let n = self.u32()?;
        let mut inner = Fields {
            rest: self.take(n)?,
        };
        while !inner.rest.is_empty() {
            entry(&mut inner)?;
        }
        Some(())
    }
}

/// Do the declared lengths of the record with opcode `op` fit in `body`?
pub fn lengths_fit(op: u8, body: &[u8]) -> bool {
    let mut f = Fields { rest: body };
    let f = &mut f;
    let string_map = |m: &mut Fields| {
        m.bytes32()?;
        m.bytes32()
    };
    let fits = match op {
        // Header: profile, library.
        0x01 => f.bytes32().and_then(|_| f.bytes32()),
        // Schema: id, name, encoding, data.
        0x03 => f
            .skip(2)
            .and_then(|_| f.bytes32())
            .and_then(|_| f.bytes32())
            .and_then(|_| f.bytes32()),
        // Channel: id, schema id, topic, encoding, metadata.
        0x04 => f
            .skip(4)
            .and_then(|_| f.bytes32())
            .and_then(|_| f.bytes32())
            .and_then(|_| f.sized(string_map)),
        // Chunk: times, uncompressed size and CRC, compression, records.
        0x06 => f
            .skip(28)
            .and_then(|_| f.bytes32())
            .and_then(|_| f.bytes64()),
        // Message index: channel, (time, offset) pairs.
        0x07 => f.skip(2).and_then(|_| f.sized(|e| e.skip(16))),
        // Chunk index: times, offset, length, per-channel offsets, index
        // length, compression, sizes.
        0x08 => f
            .skip(32)
            .and_then(|_| f.sized(|e| e.skip(10)))
            .and_then(|_| f.skip(8))
            .and_then(|_| f.bytes32())
            .and_then(|_| f.skip(16)),
        // Attachment: times, name, media type, data, CRC.
        0x09 => f
            .skip(16)
            .and_then(|_| f.bytes32())
            .and_then(|_| f.bytes32())
            .and_then(|_| f.bytes64()),
        // Attachment index: offset, length, times, size, name, media type.
        0x0A => f
            .skip(40)
            .and_then(|_| f.bytes32())
            .and_then(|_| f.bytes32()),
        // Statistics: counts and times, then per-channel message counts.
        0x0B => f.skip(42).and_then(|_| f.sized(|e| e.skip(10))),
        // Metadata: name, map.
        0x0C => f.bytes32().and_then(|_| f.sized(string_map)),
        // Metadata index: offset, length, name.
        0x0D => f.skip(16).and_then(|_| f.bytes32()),
        // Footer, message, summary offset, data end and private records
        // have no length-prefixed fields the parser allocates ahead.
        _ => Some(()),
    };
    fits.is_some()
}

/// Does an uncompressed chunk's records array hold whole records (opcode,
/// u64 length, body)? The mcap crate's reader subtracts each record from
/// what remains of the chunk without checking. Compressed chunks are
/// checked by their decompressor's sizes.
pub fn chunk_records_fit(chunk: &[u8]) -> bool {
    let mut f = Fields { rest: chunk };
    let Some(compression) = f.skip(28).and_then(|_| f.u32()).and_then(|n| f.take(n)) else {
        return false;
    };
    let Some(records) = f.u64().and_then(|n| f.take(n)) else {
        return false;
    };
    if !compression.is_empty() {
        return true;
    }
    let mut r = Fields { rest: records };
    while !r.rest.is_empty() {
        if r.skip(1)
            .and_then(|_| r.u64())
            .and_then(|n| r.skip(n))
            .is_none()
        {
            return false;
        }
    }
    true
}

/// Where the first top-level chunk (after the magic) holds a record
/// running past its end, if one does.
pub fn first_bad_chunk(file: &[u8]) -> Option<usize> {
    let mut at = 8;
    while at + 9 <= file.len() {
        let op = file[at];
        let mut len = [0u8; 8];
        len.copy_from_slice(&file[at + 1..at + 9]);
        let end = usize::try_from(u64::from_le_bytes(len))
            .ok()
            .and_then(|n| (at + 9).checked_add(n))
            .filter(|e| *e <= file.len())?;
        if op == 0x06 && !chunk_records_fit(&file[at + 9..end]) {
            return Some(at);
        }
        at = end;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn string(s: &str) -> Vec<u8> {
        let mut v = (s.len() as u32).to_le_bytes().to_vec();
        v.extend_from_slice(s.as_bytes());
        v
    }

    #[test]
    fn lengths_within_the_record_fit_and_a_4_gb_string_does_not() {
        let mut header = string("speleo");
        header.extend(string("mcap"));
        assert!(lengths_fit(0x01, &header));
        assert!(!lengths_fit(0x01, &header[..header.len() - 1]));
        let mut metadata = string("speleo.run");
        let mut map = string("config");
        map.extend(string("[sim]"));
        metadata.extend((map.len() as u32).to_le_bytes());
        metadata.extend(&map);
        assert!(lengths_fit(0x0C, &metadata));
        let mut huge = u32::MAX.to_le_bytes().to_vec();
        huge.extend_from_slice(b"speleo");
        assert!(!lengths_fit(0x01, &huge));
        assert!(!lengths_fit(0x0C, &huge));
        // A map entry running past the map's own length.
        let mut bad = string("speleo.run");
        bad.extend(4u32.to_le_bytes());
        bad.extend(string("config"));
        assert!(!lengths_fit(0x0C, &bad));
    }

    #[test]
    fn a_chunk_record_running_past_the_chunk_is_found() {
        let chunk = |inner: &[u8]| {
            let mut c = vec![0u8; 28];
            c.extend(0u32.to_le_bytes());
            c.extend((inner.len() as u64).to_le_bytes());
            c.extend_from_slice(inner);
            c
        };
        let mut whole = vec![0x05];
        whole.extend(3u64.to_le_bytes());
        whole.extend([1, 2, 3]);
        assert!(chunk_records_fit(&chunk(&whole)));
        let mut long = vec![0x05];
        long.extend(4u64.to_le_bytes());
        long.extend([1, 2, 3]);
        assert!(!chunk_records_fit(&chunk(&long)));
        let mut file = vec![0u8; 8];
        for c in [chunk(&whole), chunk(&long)] {
            file.push(0x06);
            file.extend((c.len() as u64).to_le_bytes());
            file.extend(c);
        }
        assert_eq!(first_bad_chunk(&file), Some(8 + 9 + 28 + 12 + 12));
    }
}
