//! The Xsens MTi on a serial port, read without blocking.

use std::io::{ErrorKind, Read, Write};
use std::time::Duration;

use crate::{Device, HalError, ImuPort, InputSink};

/// Bytes read per poll at most; at 921600 baud a 10 ms frame carries ~920.
const READ_CHUNK: usize = 4096;

pub struct SerialImu {
    port: Box<dyn serialport::SerialPort>,
    buf: Box<[u8; READ_CHUNK]>,
    clock: fn() -> u64,
}

fn io(source: std::io::Error) -> HalError {
    HalError::Io {
        device: "imu",
        source,
    }
}

impl SerialImu {
    pub fn open(path: &str, baud: u32, clock: fn() -> u64) -> Result<Self, HalError> {
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
            clock,
        })
    }
}

impl ImuPort for SerialImu {
    fn poll(&mut self, _now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        let waiting = self
            .port
            .bytes_to_read()
            .map_err(|e| io(std::io::Error::other(e)))?;
        if waiting == 0 {
            return Ok(());
        }
        let n = (waiting as usize).min(READ_CHUNK);
        match self.port.read(&mut self.buf[..n]) {
            Ok(0) => Ok(()),
            Ok(got) => {
                sink.input(Device::Imu, (self.clock)(), &self.buf[..got]);
                Ok(())
            }
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                ) =>
            {
                Ok(())
            }
            Err(e) => Err(io(e)),
        }
    }

    fn write(&mut self, bytes: &[u8]) -> Result<(), HalError> {
        self.port.write_all(bytes).map_err(io)
    }
}
