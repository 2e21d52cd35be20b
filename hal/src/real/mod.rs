//! Transports to the real devices: UDP for the HDL-32E, a serial port for the
//! Xsens MTi, SocketCAN for the CiA 402 drives.

pub mod serial_imu;
pub mod socketcan;
pub mod udp_lidar;

use std::net::SocketAddr;

use crate::{CanBus, HalError, Hardware, ImuPort, LidarSource};

/// Where the devices are.
#[derive(Clone, Debug)]
pub struct DeviceSettings {
    pub lidar_bind: String,
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
        crate::real::clock::start();
        Ok(RealHardware {
            lidar: udp_lidar::UdpLidar::bind(
                addr("lidar_bind", &s.lidar_bind)?,
                addr("lidar_sensor", &s.lidar_sensor)?,
                clock::now_ns,
            )?,
            imu: serial_imu::SerialImu::open(&s.imu_port, s.imu_baud, clock::now_ns)?,
            can: socketcan::SocketCan::open(&s.can_interface, clock::now_ns)?,
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

/// Receive-time clock shared by the real transports.
pub mod clock {
    use std::sync::atomic::{AtomicU64, Ordering};

    static ORIGIN: AtomicU64 = AtomicU64::new(0);

    fn monotonic() -> u64 {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: valid out-pointer; CLOCK_MONOTONIC always exists on Linux.
        unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
        ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
    }

    /// Set time zero to now.
    pub fn start() {
        ORIGIN.store(monotonic(), Ordering::Relaxed);
    }

    /// Nanoseconds since [`start`].
    pub fn now_ns() -> u64 {
        monotonic().saturating_sub(ORIGIN.load(Ordering::Relaxed))
    }
}
