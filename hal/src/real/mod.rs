//! Transports to the real devices: UDP for the HDL-32E, a serial port for the
//! Xsens MTi, SocketCAN or a serial-line (slcan) adapter for the CiA 402
//! drives.

pub mod serial_imu;
pub mod slcan_bus;
pub mod socketcan;
pub mod udp_lidar;

/// Read what a serial port has waiting, without blocking, into `buf`; the
/// count read (0: nothing waiting).
pub(crate) fn read_waiting(
    port: &mut dyn serialport::SerialPort,
    buf: &mut [u8],
) -> std::io::Result<usize> {
    let waiting = port.bytes_to_read().map_err(std::io::Error::other)?;
    if waiting == 0 {
        return Ok(0);
    }
    let n = (waiting as usize).min(buf.len());
    match port.read(&mut buf[..n]) {
        Ok(got) => Ok(got),
        Err(e)
            if matches!(
                e.kind(),
                std::io::ErrorKind::TimedOut
                    | std::io::ErrorKind::WouldBlock
                    | std::io::ErrorKind::Interrupted
            ) =>
        {
            Ok(0)
        }
        Err(e) => Err(e),
    }
}

/// A pseudo-terminal pair stands in for a device's serial line in tests.
#[cfg(test)]
pub(crate) mod tests_pty {
    /// The device's end (the master) and the path of the port's end.
    pub(crate) fn pty() -> (std::fs::File, String) {
        use std::os::fd::FromRawFd;
        // SAFETY: plain libc calls on a descriptor this function owns; the
        // name returned by ptsname is copied before any other pty call.
        unsafe {
            let master = libc::posix_openpt(libc::O_RDWR | libc::O_NOCTTY);
            assert!(master >= 0, "posix_openpt");
            assert_eq!(libc::grantpt(master), 0);
            assert_eq!(libc::unlockpt(master), 0);
            let name = std::ffi::CStr::from_ptr(libc::ptsname(master))
                .to_string_lossy()
                .into_owned();
            (std::fs::File::from_raw_fd(master), name)
        }
    }
}

use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crate::{CanBus, HalError, Hardware, ImuPort, LidarSource, TimeSource};

/// Where the devices are.
#[derive(Clone, Debug)]
pub struct DeviceSettings {
    pub lidar_bind: String,
    /// Where position packets are received (empty: not at all).
    pub lidar_position_bind: String,
    pub lidar_sensor: String,
    pub imu_port: String,
    pub imu_baud: u32,
    pub can: CanTransport,
}

/// How the drives' CAN bus is reached.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CanTransport {
    /// A kernel CAN interface by name (`can0`).
    SocketCan(String),
    /// A serial-line CAN adapter: its port, the serial rate, the bus's bit rate.
    Slcan {
        port: String,
        baud: u32,
        bit_rate: u32,
    },
}

/// The real rover. Receive times are `CLOCK_MONOTONIC` nanoseconds relative
/// to the moment the hardware was opened, the executive's time base.
pub struct RealHardware {
    time: Arc<MonotonicTime>,
    lidar: udp_lidar::UdpLidar,
    imu: serial_imu::SerialImu,
    can: Box<dyn CanBus>,
}

impl RealHardware {
    /// Open every device; the error names the one that failed.
    pub fn open(s: &DeviceSettings) -> Result<Self, HalError> {
        let addr = |key: &str, v: &str| -> Result<SocketAddr, HalError> {
            v.parse()
                .map_err(|e| HalError::Config(format!("devices.{key} = \"{v}\": {e}")))
        };
        let clock = Arc::new(MonotonicTime::start());
        let time: Arc<dyn TimeSource> = clock.clone();
        Ok(RealHardware {
            time: clock,
            lidar: {
                let l = udp_lidar::UdpLidar::bind(
                    addr("lidar_bind", &s.lidar_bind)?,
                    addr("lidar_sensor", &s.lidar_sensor)?,
                    time.clone(),
                )?;
                if s.lidar_position_bind.is_empty() {
                    l
                } else {
                    l.with_position(addr("lidar_position_bind", &s.lidar_position_bind)?)?
                }
            },
            imu: serial_imu::SerialImu::open(&s.imu_port, s.imu_baud, time.clone())?,
            can: match &s.can {
                CanTransport::SocketCan(name) => Box::new(socketcan::SocketCan::open(name, time)?),
                CanTransport::Slcan {
                    port,
                    baud,
                    bit_rate,
                } => Box::new(slcan_bus::SlcanBus::open(port, *baud, *bit_rate, time)?),
            },
        })
    }
}

impl Hardware for RealHardware {
    fn start_receive_clock(&mut self) {
        self.time.restart();
    }
    fn receive_clock_ns(&self) -> Option<u64> {
        Some(self.time.now_ns())
    }
    fn lidar(&mut self) -> &mut dyn LidarSource {
        &mut self.lidar
    }
    fn imu(&mut self) -> &mut dyn ImuPort {
        &mut self.imu
    }
    fn can(&mut self) -> &mut dyn CanBus {
        self.can.as_mut()
    }
}

/// `CLOCK_MONOTONIC` nanoseconds since [`MonotonicTime::start`].
pub struct MonotonicTime {
    origin: AtomicU64,
}

fn monotonic() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: valid out-pointer; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

impl MonotonicTime {
    /// Time zero is now.
    pub fn start() -> Self {
        MonotonicTime {
            origin: AtomicU64::new(monotonic()),
        }
    }

    /// Time zero is now, again.
    pub fn restart(&self) {
        self.origin.store(monotonic(), Ordering::Relaxed);
    }
}

impl TimeSource for MonotonicTime {
    fn now_ns(&self) -> u64 {
        monotonic().saturating_sub(self.origin.load(Ordering::Relaxed))
    }
}

/// A time source that always reads the same time (tests).
pub struct FixedTime(pub u64);

impl TimeSource for FixedTime {
    fn now_ns(&self) -> u64 {
        self.0
    }
}
