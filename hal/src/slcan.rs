//! The Lawicel serial-line CAN protocol (slcan), as CANUSB, CANable and
//! USBtin adapters speak it and Linux's `slcand` attaches it: each frame is
//! an ASCII line ended by a carriage return.
//!
//! - `tiiildd..` a standard data frame: 3 hex digits of identifier, the
//!   length (0-8), two hex digits a byte; `Tiiiiiiiildd..` extended (8
//!   digits, up to 0x1FFFFFFF); `riiil` and `Riiiiiiiil` remote frames.
//!   Adapters with time stamps on (`Z1`) add 4 hex digits of milliseconds.
//! - Commands: `Sn` the bit rate (`S0` 10 kbit/s to `S8` 1 Mbit/s), `O`
//!   open, `C` close. An adapter answers a command with a carriage return,
//!   a sent frame with `z` (standard) or `Z` (extended) and a carriage
//!   return, and refuses with BEL (0x07).
//!
//! The decoder works on a fixed buffer: a line that is too long or not a
//! frame is counted and dropped, and decoding starts again after the next
//! carriage return; nothing panics and nothing allocates.

use crate::can::CanFrame;

/// The longest valid line: `T`, 8 digits of identifier, the length, 16
/// digits of data and 4 of time stamp.
pub const MAX_LINE: usize = 1 + 8 + 1 + 16 + 4;

const CR: u8 = b'\r';
const BEL: u8 = 0x07;

/// The bit rates of the `Sn` command, in bit/s, by `n`.
pub const BIT_RATES: [u32; 9] = [
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

/// The `Sn` command for `bit_rate`, or `None` when the protocol has none.
pub fn bit_rate_command(bit_rate: u32) -> Option<[u8; 3]> {
    let n = BIT_RATES.iter().position(|&b| b == bit_rate)?;
    Some([b'S', b'0' + n as u8, CR])
}

/// What a line from an adapter said.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// A frame received from the bus, with the adapter's millisecond time
    /// stamp (0-59,999) when it sends them.
    Frame(CanFrame, Option<u16>),
    /// A command or a sent frame was accepted (an empty line, `z` or `Z`).
    Ack,
    /// The adapter refused a command or a frame (BEL).
    Refused,
}

/// Why a line is not a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineError {
    /// Longer than any frame.
    TooLong,
    /// Not a frame, an answer or a time stamp: the first byte.
    UnknownKind(u8),
    /// A character that should be a hexadecimal digit is not.
    NotHex,
    /// The length is not a digit from 0 to 8.
    BadLength,
    /// A standard identifier above 0x7FF or an extended one above 0x1FFFFFFF.
    BadId,
    /// The line's size does not match its length.
    WrongSize,
}

/// What the decoder has counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlcanCounters {
    pub frames: u64,
    pub acks: u64,
    pub refusals: u64,
    /// Lines dropped: not a frame, not an answer, or too long.
    pub bad_lines: u64,
}

fn hex(b: u8) -> Result<u32, LineError> {
    (b as char).to_digit(16).ok_or(LineError::NotHex)
}

fn hex_value(digits: &[u8]) -> Result<u32, LineError> {
    digits.iter().try_fold(0u32, |v, &d| Ok((v << 4) | hex(d)?))
}

/// Decode one line (without its carriage return).
pub fn decode_line(line: &[u8]) -> Result<Event, LineError> {
    let Some((&kind, rest)) = line.split_first() else {
        return Ok(Event::Ack);
    };
    let (extended, rtr) = match kind {
        b't' => (false, false),
        b'T' => (true, false),
        b'r' => (false, true),
        b'R' => (true, true),
        b'z' | b'Z' if rest.is_empty() => return Ok(Event::Ack),
        other => return Err(LineError::UnknownKind(other)),
    };
    let id_digits = if extended { 8 } else { 3 };
    if rest.len() < id_digits + 1 {
        return Err(LineError::WrongSize);
    }
    let id = hex_value(&rest[..id_digits])?;
    if id > if extended { 0x1fff_ffff } else { 0x7ff } {
        return Err(LineError::BadId);
    }
    let len = match rest[id_digits] {
        d @ b'0'..=b'8' => d - b'0',
        _ => return Err(LineError::BadLength),
    };
    let body = &rest[id_digits + 1..];
    let data_digits = if rtr { 0 } else { 2 * len as usize };
    let stamp = match body.len().checked_sub(data_digits) {
        Some(0) => None,
        Some(4) => Some(hex_value(&body[data_digits..])? as u16),
        _ => return Err(LineError::WrongSize),
    };
    let mut data = [0u8; 8];
    for (i, pair) in body[..data_digits].chunks_exact(2).enumerate() {
        data[i] = hex_value(pair)? as u8;
    }
    Ok(Event::Frame(
        CanFrame {
            id,
            extended,
            rtr,
            len,
            data,
        },
        stamp,
    ))
}

/// The line that sends `f` (with its carriage return), in a fixed buffer;
/// returns the buffer and the line's length.
pub fn encode_frame(f: &CanFrame) -> ([u8; MAX_LINE + 1], usize) {
    const DIGITS: &[u8; 16] = b"0123456789ABCDEF";
    let mut out = [0u8; MAX_LINE + 1];
    out[0] = match (f.extended, f.rtr) {
        (false, false) => b't',
        (true, false) => b'T',
        (false, true) => b'r',
        (true, true) => b'R',
    };
    let digits = if f.extended { 8 } else { 3 };
    let id = if f.extended {
        f.id & 0x1fff_ffff
    } else {
        f.id & 0x7ff
    };
    for k in 0..digits {
        out[1 + k] = DIGITS[((id >> (4 * (digits - 1 - k))) & 0xf) as usize];
    }
    let len = f.len.min(8);
    let mut n = 1 + digits;
    out[n] = b'0' + len;
    n += 1;
    if !f.rtr {
        for b in &f.data[..len as usize] {
            out[n] = DIGITS[(b >> 4) as usize];
            out[n + 1] = DIGITS[(b & 0xf) as usize];
            n += 2;
        }
    }
    out[n] = CR;
    (out, n + 1)
}

/// Splits an adapter's byte stream into lines and decodes them.
#[derive(Clone, Debug, Default)]
pub struct SlcanDecoder {
    line: [u8; MAX_LINE],
    len: usize,
    /// The current line outgrew the buffer: skip to its end.
    overlong: bool,
    pub counters: SlcanCounters,
}

impl SlcanDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Feed received bytes; `on_event` gets every frame and answer whole.
    pub fn feed(&mut self, bytes: &[u8], mut on_event: impl FnMut(Event)) {
        for &b in bytes {
            match b {
                CR => {
                    let line = &self.line[..self.len];
                    let event = if self.overlong {
                        Err(LineError::TooLong)
                    } else {
                        decode_line(line)
                    };
                    self.len = 0;
                    self.overlong = false;
                    match event {
                        Ok(e) => {
                            match e {
                                Event::Frame(..) => self.counters.frames += 1,
                                Event::Ack => self.counters.acks += 1,
                                Event::Refused => self.counters.refusals += 1,
                            }
                            on_event(e);
                        }
                        Err(_) => self.counters.bad_lines += 1,
                    }
                }
                BEL => {
                    // A refusal has no carriage return of its own.
                    self.counters.refusals += 1;
                    on_event(Event::Refused);
                }
                // Adapters may end lines with CR LF.
                b'\n' if self.len == 0 && !self.overlong => {}
                _ if self.len < MAX_LINE => {
                    self.line[self.len] = b;
                    self.len += 1;
                }
                _ => self.overlong = true,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(line: &str) -> CanFrame {
        match decode_line(line.as_bytes()) {
            Ok(Event::Frame(f, _)) => f,
            other => panic!("{line}: {other:?}"),
        }
    }

    #[test]
    fn the_protocols_published_examples_decode() {
        // Lawicel's CAN232/CANUSB manual and an EasySYNC adapter guide.
        let f = frame("t1002AA33");
        assert_eq!(
            (f.id, f.extended, f.payload()),
            (0x100, false, &[0xAA, 0x33][..])
        );
        let f = frame("t34580123456789ABCDEF");
        assert_eq!(f.id, 0x345);
        assert_eq!(
            f.payload(),
            &[0x01, 0x23, 0x45, 0x67, 0x89, 0xAB, 0xCD, 0xEF]
        );
        let f = frame("t4560");
        assert_eq!((f.id, f.len), (0x456, 0));
        let f = frame("T1234567880123456789ABCDEF");
        assert_eq!((f.id, f.extended, f.len), (0x1234_5678, true, 8));
        let f = frame("T123456780");
        assert_eq!((f.id, f.extended, f.len), (0x1234_5678, true, 0));
        let f = frame("r1230");
        assert!(f.rtr && !f.extended && f.id == 0x123);
        // With a time stamp (Z1): 4 digits of milliseconds after the data.
        assert_eq!(
            decode_line(b"t1002AA33EA5F"),
            Ok(Event::Frame(
                CanFrame::new(0x100, &[0xAA, 0x33]),
                Some(0xEA5F)
            ))
        );
    }

    #[test]
    fn frames_encode_to_the_lines_they_decode_from() {
        for line in [
            "t1002AA33",
            "t34580123456789ABCDEF",
            "T123456780",
            "r1230",
            "R1FFFFFFF8",
        ] {
            let (buf, n) = encode_frame(&frame(line));
            assert_eq!(&buf[..n - 1], line.as_bytes());
            assert_eq!(buf[n - 1], b'\r');
        }
        // The CiA 402 drives' own traffic: an RPDO to node 3.
        let f = CanFrame::new(0x203, &[0x0f, 0x00, 0xe8, 0x03, 0, 0, 0, 0]);
        let (buf, n) = encode_frame(&f);
        assert_eq!(&buf[..n], b"t20380F00E80300000000\r");
    }

    #[test]
    fn bad_lines_are_named() {
        assert_eq!(decode_line(b"x123"), Err(LineError::UnknownKind(b'x')));
        assert_eq!(decode_line(b"t12G0"), Err(LineError::NotHex));
        assert_eq!(decode_line(b"t1239"), Err(LineError::BadLength));
        assert_eq!(decode_line(b"t800"), Err(LineError::WrongSize));
        assert_eq!(decode_line(b"t8000"), Err(LineError::BadId));
        assert_eq!(decode_line(b"T200000000"), Err(LineError::BadId));
        assert_eq!(decode_line(b"t1232AA"), Err(LineError::WrongSize));
        assert_eq!(decode_line(b"t1231AA0"), Err(LineError::WrongSize));
        assert_eq!(decode_line(b"z"), Ok(Event::Ack));
        assert_eq!(decode_line(b""), Ok(Event::Ack));
    }

    #[test]
    fn a_stream_with_garbage_loses_only_the_bad_lines() {
        let mut d = SlcanDecoder::new();
        let mut got = Vec::new();
        let mut stream = b"t1002AA33\rgarbage\r".to_vec();
        stream.extend_from_slice(&[b'9'; 100]);
        stream.extend_from_slice(b"\rz\r\x07t4560\r\nT123456780\r");
        // Byte by byte: lines split across reads decode the same.
        for b in &stream {
            d.feed(std::slice::from_ref(b), |e| got.push(e));
        }
        let frames: Vec<u32> = got
            .iter()
            .filter_map(|e| match e {
                Event::Frame(f, _) => Some(f.id),
                _ => None,
            })
            .collect();
        assert_eq!(frames, [0x100, 0x456, 0x1234_5678]);
        assert_eq!(
            d.counters,
            SlcanCounters {
                frames: 3,
                acks: 1,
                refusals: 1,
                bad_lines: 2
            }
        );
    }

    #[test]
    fn bit_rates_have_their_commands() {
        assert_eq!(bit_rate_command(1_000_000), Some(*b"S8\r"));
        assert_eq!(bit_rate_command(10_000), Some(*b"S0\r"));
        assert_eq!(bit_rate_command(83_333), None);
    }
}
