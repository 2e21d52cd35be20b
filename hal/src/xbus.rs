//! Xsens Xbus framing and the MTData2 items Speleo uses.
//!
//! Frame: `0xFA` preamble, bus id, message id, length (`0xFF` announces a
//! 16-bit big-endian extended length), payload, checksum. The low byte of the
//! sum of every byte after the preamble, checksum included, is zero. All
//! multi-byte values are big-endian.
//!
//! The decoder is a byte-stream state machine with a fixed buffer: garbage
//! before a preamble is skipped and counted, a bad checksum drops only the
//! preamble byte so that a frame hidden inside garbage is still found.

pub const PREAMBLE: u8 = 0xFA;
pub const BID_MASTER: u8 = 0xFF;
pub const MID_MTDATA2: u8 = 0x36;
pub const MID_GOTO_CONFIG: u8 = 0x30;
pub const MID_GOTO_MEASUREMENT: u8 = 0x10;
pub const MID_ERROR: u8 = 0x42;

/// MTData2 data identifiers (Float32, ENU).
pub mod did {
    pub const PACKET_COUNTER: u16 = 0x1020;
    pub const SAMPLE_TIME_FINE: u16 = 0x1060;
    pub const QUATERNION: u16 = 0x2010;
    pub const ACCELERATION: u16 = 0x4020;
    pub const RATE_OF_TURN: u16 = 0x8020;
    pub const STATUS_WORD: u16 = 0xE020;
}

/// Largest frame the decoder buffers (header, extended length, payload, checksum).
pub const MAX_FRAME: usize = 1024;

/// Append a complete frame to `out`. Returns false (and leaves `out` as it
/// was) when it does not fit.
pub fn encode_frame<const N: usize>(
    mid: u8,
    payload: &[u8],
    out: &mut heapless::Vec<u8, N>,
) -> bool {
    let start = out.len();
    let ok = (|| -> Result<(), ()> {
        out.push(PREAMBLE).map_err(drop)?;
        out.push(BID_MASTER).map_err(drop)?;
        out.push(mid).map_err(drop)?;
        if payload.len() < 0xFF {
            out.push(payload.len() as u8).map_err(drop)?;
        } else {
            let n = u16::try_from(payload.len()).map_err(drop)?;
            out.push(0xFF).map_err(drop)?;
            out.extend_from_slice(&n.to_be_bytes()).map_err(drop)?;
        }
        out.extend_from_slice(payload).map_err(drop)?;
        let sum = out[start + 1..].iter().fold(0u8, |s, &b| s.wrapping_add(b));
        out.push(0u8.wrapping_sub(sum)).map_err(drop)?;
        Ok(())
    })()
    .is_ok();
    if !ok {
        out.truncate(start);
    }
    ok
}

/// Builds an MTData2 payload item by item.
#[derive(Default)]
pub struct Mtdata2Builder {
    buf: heapless::Vec<u8, 255>,
}

impl Mtdata2Builder {
    pub fn new() -> Self {
        Self::default()
    }

    fn item(&mut self, id: u16, data: &[u8]) -> &mut Self {
        if self.buf.len() + 3 + data.len() <= self.buf.capacity() {
            let _ = self.buf.extend_from_slice(&id.to_be_bytes());
            let _ = self.buf.push(data.len() as u8);
            let _ = self.buf.extend_from_slice(data);
        }
        self
    }

    pub fn u16(&mut self, id: u16, v: u16) -> &mut Self {
        self.item(id, &v.to_be_bytes())
    }

    pub fn u32(&mut self, id: u16, v: u32) -> &mut Self {
        self.item(id, &v.to_be_bytes())
    }

    pub fn f32s(&mut self, id: u16, v: &[f32]) -> &mut Self {
        let mut d: heapless::Vec<u8, 64> = heapless::Vec::new();
        for x in v {
            let _ = d.extend_from_slice(&x.to_be_bytes());
        }
        self.item(id, &d)
    }

    pub fn payload(&self) -> &[u8] {
        &self.buf
    }
}

/// The MTData2 items Speleo reads. Items not present stay `None`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImuData {
    pub packet_counter: Option<u16>,
    /// 10 kHz ticks.
    pub sample_time_fine: Option<u32>,
    /// w, x, y, z.
    pub quaternion: Option<[f32; 4]>,
    /// m/s^2, sensor frame.
    pub acceleration: Option<[f32; 3]>,
    /// rad/s, sensor frame.
    pub rate_of_turn: Option<[f32; 3]>,
    pub status_word: Option<u32>,
}

/// An MTData2 payload that ends inside an item.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TruncatedItem {
    pub offset: usize,
}

/// Parse an MTData2 payload into the items the on-board software uses, in
/// any precision. Unknown identifiers and known ones with an unexpected size
/// are skipped by their size field.
pub fn parse_mtdata2(payload: &[u8]) -> Result<ImuData, TruncatedItem> {
    use crate::mtdata2::{items, Item, Kind};
    let mut out = ImuData::default();
    for it in items(payload) {
        let (_, item) = it.map_err(|t| TruncatedItem { offset: t.offset })?;
        match item {
            Item::PacketCounter(c) => out.packet_counter = Some(c),
            Item::SampleTimeFine(t) => out.sample_time_fine = Some(t),
            Item::StatusWord(w) => out.status_word = Some(w),
            Item::Numbers {
                kind, values: v, ..
            } => match kind {
                Kind::Quaternion => {
                    out.quaternion = Some([v[0] as f32, v[1] as f32, v[2] as f32, v[3] as f32])
                }
                Kind::Acceleration => {
                    out.acceleration = Some([v[0] as f32, v[1] as f32, v[2] as f32])
                }
                Kind::RateOfTurn => {
                    out.rate_of_turn = Some([v[0] as f32, v[1] as f32, v[2] as f32])
                }
                _ => {}
            },
            _ => {}
        }
    }
    Ok(out)
}

/// Counters of the stream decoder.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct XbusCounters {
    pub frames: u64,
    pub bad_checksums: u64,
    /// Bytes dropped while looking for a preamble.
    pub skipped_bytes: u64,
    /// Frames announcing more than [`MAX_FRAME`] bytes.
    pub oversize: u64,
}

/// A decoded frame, borrowed from the decoder's buffer.
#[derive(Debug, PartialEq, Eq)]
pub struct XbusFrame<'a> {
    pub bid: u8,
    pub mid: u8,
    pub payload: &'a [u8],
}

/// Stream decoder with a fixed buffer of [`MAX_FRAME`] bytes.
#[derive(Default)]
pub struct XbusDecoder {
    buf: heapless::Vec<u8, MAX_FRAME>,
    pub counters: XbusCounters,
}

impl XbusDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Feed received bytes; `on_frame` is called for every valid frame.
    pub fn push(&mut self, mut bytes: &[u8], on_frame: &mut dyn FnMut(XbusFrame<'_>)) {
        while !bytes.is_empty() {
            let room = self.buf.capacity() - self.buf.len();
            let n = room.min(bytes.len());
            let _ = self.buf.extend_from_slice(&bytes[..n]);
            bytes = &bytes[n..];
            self.drain(on_frame);
        }
    }

    fn drop_front(&mut self, n: usize) {
        let n = n.min(self.buf.len());
        self.buf.copy_within(n.., 0);
        let keep = self.buf.len() - n;
        self.buf.truncate(keep);
    }

    fn drain(&mut self, on_frame: &mut dyn FnMut(XbusFrame<'_>)) {
        loop {
            // Find a preamble.
            match self.buf.iter().position(|&b| b == PREAMBLE) {
                Some(0) => {}
                Some(p) => {
                    self.counters.skipped_bytes += p as u64;
                    self.drop_front(p);
                }
                None => {
                    self.counters.skipped_bytes += self.buf.len() as u64;
                    self.buf.clear();
                    return;
                }
            }
            if self.buf.len() < 2 {
                return;
            }
            // Everything the MTi sends carries the master bus id; a preamble
            // followed by anything else is garbage, and rejecting it here
            // keeps a false length from holding back the real frames.
            if self.buf[1] != BID_MASTER {
                self.counters.skipped_bytes += 1;
                self.drop_front(1);
                continue;
            }
            if self.buf.len() < 4 {
                return;
            }
            let (header, len) = if self.buf[3] == 0xFF {
                if self.buf.len() < 6 {
                    return;
                }
                (6, u16::from_be_bytes([self.buf[4], self.buf[5]]) as usize)
            } else {
                (4, self.buf[3] as usize)
            };
            let total = header + len + 1;
            if total > MAX_FRAME {
                self.counters.oversize += 1;
                self.counters.skipped_bytes += 1;
                self.drop_front(1);
                continue;
            }
            if self.buf.len() < total {
                return;
            }
            let sum = self.buf[1..total]
                .iter()
                .fold(0u8, |s, &b| s.wrapping_add(b));
            if sum != 0 {
                self.counters.bad_checksums += 1;
                self.counters.skipped_bytes += 1;
                self.drop_front(1);
                continue;
            }
            self.counters.frames += 1;
            on_frame(XbusFrame {
                bid: self.buf[1],
                mid: self.buf[2],
                payload: &self.buf[header..header + len],
            });
            self.drop_front(total);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_frame() -> heapless::Vec<u8, 256> {
        let mut b = Mtdata2Builder::new();
        b.u16(did::PACKET_COUNTER, 42)
            .u32(did::SAMPLE_TIME_FINE, 100_000)
            .f32s(did::QUATERNION, &[1.0, 0.0, 0.0, 0.0])
            .f32s(did::ACCELERATION, &[0.1, -0.2, 9.81])
            .f32s(did::RATE_OF_TURN, &[0.0, 0.0, 0.5])
            .u32(did::STATUS_WORD, 3);
        let mut out = heapless::Vec::new();
        assert!(encode_frame(MID_MTDATA2, b.payload(), &mut out));
        out
    }

    #[test]
    fn the_manual_example_checksum() {
        // ReqDID = FA FF 00 00 01 (MTi user manual).
        let mut out: heapless::Vec<u8, 8> = heapless::Vec::new();
        assert!(encode_frame(0x00, &[], &mut out));
        assert_eq!(&out[..], &[0xFA, 0xFF, 0x00, 0x00, 0x01]);
    }

    #[test]
    fn frames_survive_garbage_split_reads_and_bad_checksums() {
        let frame = sample_frame();
        let mut stream = vec![0x00, 0xFA, 0x13, 0xFA];
        stream.extend_from_slice(&frame);
        let mut corrupt = frame.clone();
        corrupt[10] ^= 0x40;
        stream.extend_from_slice(&corrupt);
        stream.extend_from_slice(&frame);
        let mut d = XbusDecoder::new();
        let mut got = Vec::new();
        for chunk in stream.chunks(7) {
            d.push(chunk, &mut |f| {
                got.push(parse_mtdata2(f.payload).expect("parses"));
            });
        }
        assert_eq!(got.len(), 2);
        assert_eq!(got[0].packet_counter, Some(42));
        assert_eq!(got[0].acceleration, Some([0.1, -0.2, 9.81]));
        assert_eq!(got[1].rate_of_turn, Some([0.0, 0.0, 0.5]));
        assert_eq!(d.counters.frames, 2);
        assert!(d.counters.bad_checksums >= 1);
        assert!(d.counters.skipped_bytes >= 4);
    }

    #[test]
    fn truncated_items_are_reported_not_panicked() {
        assert_eq!(
            parse_mtdata2(&[0x10, 0x20]),
            Err(TruncatedItem { offset: 0 })
        );
        assert_eq!(
            parse_mtdata2(&[0x10, 0x20, 0x02, 0x00]),
            Err(TruncatedItem { offset: 0 })
        );
        // Unknown id skipped by size.
        let ok =
            parse_mtdata2(&[0x77, 0x77, 0x01, 0xAA, 0x10, 0x20, 0x02, 0x00, 0x05]).expect("ok");
        assert_eq!(ok.packet_counter, Some(5));
    }

    #[test]
    fn extended_length_and_oversize() {
        let payload = vec![0u8; 300];
        let mut out: heapless::Vec<u8, 400> = heapless::Vec::new();
        assert!(encode_frame(0x99, &payload, &mut out));
        assert_eq!(out[3], 0xFF);
        let mut d = XbusDecoder::new();
        let mut n = 0;
        d.push(&out, &mut |f| {
            assert_eq!(f.payload.len(), 300);
            n += 1;
        });
        assert_eq!(n, 1);
        // A header announcing 60000 bytes is skipped, the following frame kept.
        let mut s = vec![0xFA, 0xFF, 0x36, 0xFF, 0xEA, 0x60];
        s.extend_from_slice(&sample_frame());
        let mut n = 0;
        d.push(&s, &mut |_| n += 1);
        assert_eq!(n, 1);
        assert_eq!(d.counters.oversize, 1);
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..4096)) {
            let mut d = XbusDecoder::new();
            d.push(&bytes, &mut |f| { let _ = parse_mtdata2(f.payload); });
        }
    }
}
