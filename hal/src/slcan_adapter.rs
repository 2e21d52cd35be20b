//! The adapter's side of slcan: what a host sends a serial-line CAN adapter
//! (commands, and frames to put on the bus) and the answers a Lawicel-style
//! adapter gives. The drive twins speak it when they stand in for the
//! rover's bus behind an slcan adapter.

use crate::can::CanFrame;
use crate::slcan::{decode_line, Event, LineError, BIT_RATES, MAX_LINE};

const CR: u8 = b'\r';
const BEL: u8 = 0x07;

/// One line from the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostLine {
    /// `O`: open the channel.
    Open,
    /// `L`: open it listening only.
    ListenOnly,
    /// `C`: close it.
    Close,
    /// `Sn`: the bus's bit rate, in bit/s.
    BitRate(u32),
    /// `Z0` / `Z1`: time stamps off or on.
    TimeStamps(bool),
    /// `V`: hardware and software versions.
    Version,
    /// `N`: serial number.
    SerialNumber,
    /// `F`: status flags.
    Status,
    /// `t`, `T`, `r`, `R`: a frame to send.
    Send(CanFrame),
}

/// Decode one line (without its carriage return) a host sent.
pub fn decode_host_line(line: &[u8]) -> Result<HostLine, LineError> {
    match line {
        [b'O'] => Ok(HostLine::Open),
        [b'L'] => Ok(HostLine::ListenOnly),
        [b'C'] => Ok(HostLine::Close),
        [b'V'] => Ok(HostLine::Version),
        [b'N'] => Ok(HostLine::SerialNumber),
        [b'F'] => Ok(HostLine::Status),
        [b'Z', b'0'] => Ok(HostLine::TimeStamps(false)),
        [b'Z', b'1'] => Ok(HostLine::TimeStamps(true)),
        [b'S', d @ b'0'..=b'8'] => Ok(HostLine::BitRate(BIT_RATES[(d - b'0') as usize])),
        [b't' | b'T' | b'r' | b'R', ..] => match decode_line(line)? {
            Event::Frame(f, None) => Ok(HostLine::Send(f)),
            // A host sends no time stamps.
            _ => Err(LineError::WrongSize),
        },
        [k, ..] => Err(LineError::UnknownKind(*k)),
        [] => Err(LineError::WrongSize),
    }
}

/// An adapter's state: whether its channel is open, at which bit rate.
#[derive(Clone, Debug, Default)]
pub struct Adapter {
    line: [u8; MAX_LINE],
    len: usize,
    overlong: bool,
    open: bool,
    bit_rate: Option<u32>,
    /// Lines refused: unknown, malformed, or not allowed in the state.
    pub refused: u64,
    /// Frames the host sent onto the bus.
    pub sent: u64,
}

impl Adapter {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn is_open(&self) -> bool {
        self.open
    }

    pub fn bit_rate(&self) -> Option<u32> {
        self.bit_rate
    }

    /// Feed bytes from the host: `on_frame` gets each frame to put on the
    /// bus, `answer` each answer to write back.
    pub fn feed(
        &mut self,
        bytes: &[u8],
        mut on_frame: impl FnMut(CanFrame),
        mut answer: impl FnMut(&[u8]),
    ) {
        for &b in bytes {
            if b != CR {
                if self.len < MAX_LINE {
                    self.line[self.len] = b;
                    self.len += 1;
                } else {
                    self.overlong = true;
                }
                continue;
            }
            let line = if self.overlong {
                Err(LineError::TooLong)
            } else {
                decode_host_line(&self.line[..self.len])
            };
            self.len = 0;
            self.overlong = false;
            match self.apply(line) {
                Some((reply, frame)) => {
                    if let Some(f) = frame {
                        self.sent += 1;
                        on_frame(f);
                    }
                    answer(reply);
                }
                None => {
                    self.refused += 1;
                    answer(&[BEL]);
                }
            }
        }
    }

    /// The answer to `line` in the current state, and the frame it sends;
    /// `None`: refused.
    fn apply(
        &mut self,
        line: Result<HostLine, LineError>,
    ) -> Option<(&'static [u8], Option<CanFrame>)> {
        let closed = !self.open;
        match line.ok()? {
            HostLine::Open | HostLine::ListenOnly if closed && self.bit_rate.is_some() => {
                self.open = true;
                Some((b"\r", None))
            }
            HostLine::Close if !closed => {
                self.open = false;
                Some((b"\r", None))
            }
            HostLine::BitRate(b) if closed => {
                self.bit_rate = Some(b);
                Some((b"\r", None))
            }
            HostLine::TimeStamps(_) if closed => Some((b"\r", None)),
            HostLine::Version => Some((b"V1013\r", None)),
            HostLine::SerialNumber => Some((b"NSPL1\r", None)),
            HostLine::Status if !closed => Some((b"F00\r", None)),
            HostLine::Send(f) if !closed => {
                Some((if f.extended { b"Z\r" } else { b"z\r" }, Some(f)))
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slcan::encode_frame;

    fn run(a: &mut Adapter, input: &[u8]) -> (Vec<CanFrame>, Vec<u8>) {
        let (mut frames, mut answers) = (Vec::new(), Vec::new());
        a.feed(input, |f| frames.push(f), |r| answers.extend_from_slice(r));
        (frames, answers)
    }

    #[test]
    fn the_set_up_then_frames_get_the_answers_a_lawicel_adapter_gives() {
        let mut a = Adapter::new();
        // Closing a closed channel is refused, as the real adapters do.
        let (_, r) = run(&mut a, b"C\rS8\rO\r");
        assert_eq!(r, b"\x07\r\r");
        assert!(a.is_open());
        assert_eq!(a.bit_rate(), Some(1_000_000));
        let (line, n) = encode_frame(&CanFrame::new(0x203, &[0x0f, 0x00]));
        let (frames, r) = run(&mut a, &line[..n]);
        assert_eq!(frames, [CanFrame::new(0x203, &[0x0f, 0x00])]);
        assert_eq!(r, b"z\r");
        let (frames, r) = run(&mut a, b"T123456780\r");
        assert_eq!((frames[0].id, frames[0].extended), (0x1234_5678, true));
        assert_eq!(r, b"Z\r");
    }

    #[test]
    fn what_the_state_does_not_allow_or_cannot_be_read_is_refused() {
        let mut a = Adapter::new();
        // Open before a bit rate; a frame on a closed channel; garbage.
        let (frames, r) = run(&mut a, b"O\rt1230\rxyz\r");
        assert!(frames.is_empty());
        assert_eq!(r, b"\x07\x07\x07");
        let (_, r) = run(&mut a, b"S6\rO\rS4\r");
        assert_eq!(r, b"\r\r\x07", "no new bit rate while open");
        assert_eq!(a.bit_rate(), Some(500_000));
        let mut long = vec![b't'; 100];
        long.push(b'\r');
        let (frames, r) = run(&mut a, &long);
        assert!(frames.is_empty());
        assert_eq!(r, b"\x07");
        assert_eq!(a.refused, 5);
    }
}
