//! Transports to the real devices: UDP for the HDL-32E, a serial port for the
//! Xsens MTi, SocketCAN for the CiA 402 drives.

pub mod serial_imu;
pub mod socketcan;
pub mod udp_lidar;

use std::net::SocketAddr;
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
    pub can_interface: String,
}

/// The real rover. Receive times are `CLOCK_MONOTONIC` nanoseconds relative
/// to the moment the hardware was opened, the executive's time base.
pub struct RealHardware {
    lidar: udp_lidar::UdpLidar,
    imu: serial_imu::SerialImu,
    can: socketcan::SocketCan,
}

impl RealHardware {
    /// Open every device; the error names the one that failed.
    pub fn open(s: &DeviceSettings) -> Result<Self, HalError> {
        let addr = |key: &str, v: &str| -> Result<SocketAddr, HalError> {
            v.parse()
                .map_err(|e| HalError::Config(format!("devices.{key} = \"{v}\": {e}")))
        };
        let time: Arc<dyn TimeSource> = Arc::new(MonotonicTime::start());
        Ok(RealHardware {
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
            can: socketcan::SocketCan::open(&s.can_interface, time)?,
        })
    }
}

impl Hardware for RealHardware {
    fn lidar(&mut self) -> &mut dyn LidarSource {
        &mut self.lidar
    }
    fn imu(&mut self) -> &mut dyn ImuPort {
        &mut self.imu
    }
    fn can(&mut self) -> &mut dyn CanBus {
        &mut self.can
    }
}

/// `CLOCK_MONOTONIC` nanoseconds since [`MonotonicTime::start`].
pub struct MonotonicTime {
    origin: u64,
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
            origin: monotonic(),
        }
    }
}

impl TimeSource for MonotonicTime {
    fn now_ns(&self) -> u64 {
        monotonic().saturating_sub(self.origin)
    }
}

/// A time source that always reads the same time (tests).
pub struct FixedTime(pub u64);

impl TimeSource for FixedTime {
    fn now_ns(&self) -> u64 {
        self.0
    }
}
