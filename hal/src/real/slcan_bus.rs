//! The CAN bus through a serial-line CAN adapter that speaks slcan
//! (CANable, USBtin, CANUSB). Received frames reach the drivers as
//! SocketCAN's 16-byte frames, as from a SocketCAN interface, so recordings
//! and replay are the same whichever transport the rover used. Lines that
//! are not frames are counted and dropped.

use std::io::{ErrorKind, Write};
use std::time::{Duration, Instant};

use crate::can::CanFrame;
use crate::slcan::{bit_rate_command, encode_frame, Event, SlcanCounters, SlcanDecoder, BIT_RATES};
use crate::{CanBus, Device, HalError, InputSink};

/// Bytes read per poll at most: a 1 Mbit/s bus carries about 80 frames in
/// 10 ms, 23 bytes each as slcan lines.
const READ_CHUNK: usize = 4096;
/// How long the adapter may take to answer each set-up command.
const ANSWER_WAIT: Duration = Duration::from_millis(500);

pub struct SlcanBus {
    port: Box<dyn serialport::SerialPort>,
    buf: Box<[u8; READ_CHUNK]>,
    decoder: SlcanDecoder,
    time: std::sync::Arc<dyn crate::TimeSource>,
}

fn io(source: std::io::Error) -> HalError {
    HalError::Io {
        device: "can",
        source,
    }
}

impl SlcanBus {
    /// Open the adapter on serial port `path` (`baud`: the serial line's
    /// rate; USB adapters ignore it), set the bus to `bit_rate` and open the
    /// channel. An adapter that refuses or does not answer is an error here.
    pub fn open(
        path: &str,
        baud: u32,
        bit_rate: u32,
        time: std::sync::Arc<dyn crate::TimeSource>,
    ) -> Result<Self, HalError> {
        let rate = bit_rate_command(bit_rate).ok_or_else(|| {
            HalError::Config(format!(
                "devices.can_bit_rate = {bit_rate}: slcan offers {BIT_RATES:?} bit/s"
            ))
        })?;
        let port = serialport::new(path, baud)
            .timeout(Duration::ZERO)
            .open()
            .map_err(|e| io(std::io::Error::other(format!("{path}: {e}"))))?;
        let mut bus = SlcanBus {
            port,
            buf: Box::new([0; READ_CHUNK]),
            decoder: SlcanDecoder::new(),
            time,
        };
        // Close first: an adapter left open refuses a new bit rate. Its
        // answer to that (a refusal when already closed) does not matter.
        bus.port.write_all(b"C\r").map_err(io)?;
        bus.answer(path, "C", true)?;
        for (cmd, name) in [(&rate[..], "the bit rate"), (b"O\r", "opening the channel")] {
            bus.port.write_all(cmd).map_err(io)?;
            bus.answer(path, name, false)?;
        }
        Ok(bus)
    }

    /// Wait for the adapter's answer to a command; `any`: a refusal is fine.
    fn answer(&mut self, path: &str, what: &str, any: bool) -> Result<(), HalError> {
        let until = Instant::now() + ANSWER_WAIT;
        while Instant::now() < until {
            let mut answer = None;
            let n = self.read_some()?;
            self.decoder.feed(&self.buf[..n], |e| {
                if matches!(e, Event::Ack | Event::Refused) && answer.is_none() {
                    answer = Some(e);
                }
            });
            match answer {
                Some(Event::Ack) => return Ok(()),
                Some(_) if any => return Ok(()),
                Some(_) => {
                    return Err(io(std::io::Error::other(format!(
                        "{path}: the slcan adapter refused {what}"
                    ))))
                }
                None => std::thread::sleep(Duration::from_millis(2)),
            }
        }
        Err(io(std::io::Error::other(format!(
            "{path}: no slcan answer to {what} within {} ms (is it an slcan adapter?)",
            ANSWER_WAIT.as_millis()
        ))))
    }

    /// Read what is waiting, into `buf`; the count read.
    fn read_some(&mut self) -> Result<usize, HalError> {
        super::read_waiting(self.port.as_mut(), &mut self.buf[..]).map_err(io)
    }

    /// What the decoder counted: frames, answers, refusals, bad lines.
    pub fn counters(&self) -> SlcanCounters {
        self.decoder.counters
    }
}

impl CanBus for SlcanBus {
    fn poll(&mut self, _now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        let n = self.read_some()?;
        if n == 0 {
            return Ok(());
        }
        let at = self.time.now_ns();
        self.decoder.feed(&self.buf[..n], |e| {
            if let Event::Frame(f, _) = e {
                sink.input(Device::Can, at, &f.to_socketcan());
            }
        });
        Ok(())
    }

    fn send(&mut self, _now_ns: u64, frame: &CanFrame) -> Result<(), HalError> {
        let (line, n) = encode_frame(frame);
        match self.port.write(&line[..n]) {
            Ok(k) if k == n => Ok(()),
            // A partial line would corrupt the next: end it so the adapter
            // drops it, and count the frame as not sent.
            Ok(_) => {
                let _ = self.port.write_all(b"\r");
                Err(HalError::TxFull)
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => Err(HalError::TxFull),
            Err(e) => Err(io(e)),
        }
    }

    fn dropped_input(&self) -> u64 {
        self.decoder.counters.bad_lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::real::tests_pty::pty;
    use std::io::Read;

    struct Collect(Vec<CanFrame>);
    impl InputSink for Collect {
        fn input(&mut self, d: Device, _t: u64, bytes: &[u8]) {
            assert_eq!(d, Device::Can);
            self.0
                .push(CanFrame::from_socketcan(bytes).expect("a SocketCAN frame"));
        }
    }

    /// The adapter's side: read one command line.
    fn command(adapter: &mut std::fs::File) -> Vec<u8> {
        let mut line = Vec::new();
        let mut b = [0u8; 1];
        while adapter.read_exact(&mut b).is_ok() && b[0] != b'\r' {
            line.push(b[0]);
        }
        line
    }

    #[test]
    fn the_adapter_is_set_up_then_frames_go_both_ways_and_bad_lines_are_counted() {
        let (mut adapter, path) = pty();
        let time = std::sync::Arc::new(crate::real::FixedTime(7));
        let opener = std::thread::spawn(move || SlcanBus::open(&path, 115_200, 1_000_000, time));
        // An adapter answers each command with a carriage return.
        let mut got = Vec::new();
        for _ in 0..3 {
            got.push(String::from_utf8(command(&mut adapter)).expect("ascii"));
            adapter.write_all(b"\r").expect("answer");
        }
        assert_eq!(got, ["C", "S8", "O"]);
        let mut bus = opener.join().expect("thread").expect("open");

        adapter
            .write_all(b"t1002AA33\rnot a frame\rT123456780\r")
            .expect("adapter sends");
        let mut sink = Collect(Vec::new());
        for _ in 0..100 {
            bus.poll(0, &mut sink).expect("poll");
            if sink.0.len() >= 2 {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        assert_eq!(sink.0[0], CanFrame::new(0x100, &[0xAA, 0x33]));
        assert_eq!((sink.0[1].id, sink.0[1].extended), (0x1234_5678, true));
        assert_eq!(bus.dropped_input(), 1);

        bus.send(0, &CanFrame::new(0x203, &[0x0f, 0x00]))
            .expect("send");
        assert_eq!(command(&mut adapter), b"t20320F00");
    }

    #[test]
    fn the_bus_works_with_the_adapters_own_side_of_the_protocol() {
        use crate::slcan_adapter::Adapter;
        let (mut line, path) = pty();
        // The adapter's side, answering as it reads, until told to stop.
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let s = stop.clone();
        let adapter = std::thread::spawn(move || {
            let mut a = Adapter::new();
            let mut got = Vec::new();
            let mut b = [0u8; 256];
            let fd = std::os::fd::AsRawFd::as_raw_fd(&line);
            while !s.load(std::sync::atomic::Ordering::Relaxed) {
                let mut p = libc::pollfd {
                    fd,
                    events: libc::POLLIN,
                    revents: 0,
                };
                // SAFETY: one valid pollfd.
                if unsafe { libc::poll(&mut p, 1, 10) } <= 0 {
                    continue;
                }
                let Ok(n) = line.read(&mut b) else { break };
                let mut answers = Vec::new();
                a.feed(&b[..n], |f| got.push(f), |r| answers.extend_from_slice(r));
                line.write_all(&answers).expect("answer");
            }
            (got, a.bit_rate(), line)
        });
        let time = std::sync::Arc::new(crate::real::FixedTime(0));
        let mut bus = SlcanBus::open(&path, 115_200, 250_000, time).expect("open");
        bus.send(0, &CanFrame::new(0x000, &[0x01, 0x00]))
            .expect("NMT start");
        std::thread::sleep(Duration::from_millis(100));
        stop.store(true, std::sync::atomic::Ordering::Relaxed);
        let (got, rate, _line) = adapter.join().expect("adapter");
        assert_eq!(rate, Some(250_000));
        assert_eq!(got, [CanFrame::new(0x000, &[0x01, 0x00])]);
        // Its answer to the frame (`z`) is an answer, not a bad line.
        let mut sink = Collect(Vec::new());
        bus.poll(0, &mut sink).expect("poll");
        assert!(sink.0.is_empty());
        assert_eq!(bus.dropped_input(), 0);
    }

    #[test]
    fn a_bit_rate_slcan_lacks_or_a_silent_port_is_named() {
        let time = std::sync::Arc::new(crate::real::FixedTime(0));
        let e = SlcanBus::open("/dev/null", 115_200, 83_333, time.clone())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("83333") && e.contains("slcan"), "{e}");
        // A serial line whose other end never answers.
        let (_adapter, path) = pty();
        let e = SlcanBus::open(&path, 115_200, 500_000, time)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("no slcan answer"), "{e}");
    }
}
