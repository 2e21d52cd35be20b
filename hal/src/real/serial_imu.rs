//! The Xsens MTi on a serial port, read without blocking.

use std::io::Write;
use std::time::Duration;

use crate::{Device, HalError, ImuPort, InputSink};

/// Bytes read per poll at most; at 921600 baud a 10 ms frame carries ~920.
const READ_CHUNK: usize = 4096;

pub struct SerialImu {
    port: Box<dyn serialport::SerialPort>,
    buf: Box<[u8; READ_CHUNK]>,
    time: std::sync::Arc<dyn crate::TimeSource>,
}

fn io(source: std::io::Error) -> HalError {
    HalError::Io {
        device: "imu",
        source,
    }
}

impl SerialImu {
    pub fn open(
        path: &str,
        baud: u32,
        time: std::sync::Arc<dyn crate::TimeSource>,
    ) -> Result<Self, HalError> {
        let port = serialport::new(path, baud)
            .timeout(Duration::ZERO)
            .open()
            .map_err(|e| HalError::Io {
                device: "imu",
                source: std::io::Error::other(format!("{path}: {e}")),
            })?;
        Ok(SerialImu {
            port,
            buf: Box::new([0; READ_CHUNK]),
            time,
        })
    }
}

impl ImuPort for SerialImu {
    fn poll(&mut self, _now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        let got = super::read_waiting(self.port.as_mut(), &mut self.buf[..]).map_err(io)?;
        if got > 0 {
            sink.input(Device::Imu, self.time.now_ns(), &self.buf[..got]);
        }
        Ok(())
    }

    fn write(&mut self, bytes: &[u8]) -> Result<(), HalError> {
        self.port.write_all(bytes).map_err(io)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::real::tests_pty::pty;
    use std::io::Read;

    struct Collect(Vec<u8>);
    impl InputSink for Collect {
        fn input(&mut self, d: Device, _t: u64, bytes: &[u8]) {
            assert_eq!(d, Device::Imu);
            self.0.extend_from_slice(bytes);
        }
    }

    #[test]
    fn bytes_written_by_the_device_are_received_and_commands_sent() {
        let (mut device, path) = pty();
        let mut imu = SerialImu::open(
            &path,
            921_600,
            std::sync::Arc::new(crate::real::FixedTime(42)),
        )
        .expect("open pty");
        let mut sink = Collect(Vec::new());
        imu.poll(0, &mut sink).expect("poll");
        assert!(sink.0.is_empty());
        let frame = [0xFA, 0xFF, 0x30, 0x00, 0xD1];
        device.write_all(&frame).expect("device writes");
        for _ in 0..100 {
            imu.poll(0, &mut sink).expect("poll");
            if sink.0.len() >= frame.len() {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        assert_eq!(sink.0, frame);
        imu.write(&[0xFA, 0xFF, 0x10, 0x00, 0xF1]).expect("command");
        let mut got = [0u8; 5];
        device.read_exact(&mut got).expect("device reads");
        assert_eq!(got, [0xFA, 0xFF, 0x10, 0x00, 0xF1]);
    }

    #[test]
    fn a_missing_port_is_named() {
        let e = SerialImu::open(
            "/dev/no-such-imu",
            115_200,
            std::sync::Arc::new(crate::real::FixedTime(0)),
        )
        .err()
        .map(|e| e.to_string());
        assert!(e.unwrap_or_default().contains("/dev/no-such-imu"));
    }
}
