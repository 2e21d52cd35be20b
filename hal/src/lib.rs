//! Speleo's hardware boundary.
//!
//! Everything the rover exchanges with its devices crosses these traits as raw
//! wire bytes: HDL-32E UDP packets, the Xsens serial byte stream and CAN frames
//! for the CiA 402 motor drives. Three backends sit behind them: the real
//! devices ([`real`]), the simulated hardware of the `speleo-twin` crate and
//! [`replay`] of a recording. Because the twin emits the real wire formats
//! (with this crate's encoders), sim, replay and the rover all run the same
//! decoders.

pub mod can;
pub mod canopen;
pub mod cia402;
pub mod hdl32e;
pub mod mtdata2;
pub mod outbox;
pub mod pcap;
pub mod real;
pub mod replay;
pub mod shared_data;
pub mod slcan;
pub mod slcan_adapter;
pub mod xbus;
pub mod xsens_config;

/// A file's extension in lower case ("" when it has none): file formats
/// are chosen by it.
pub fn extension_of(path: &std::path::Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

use thiserror::Error;

pub use can::CanFrame;

/// The devices whose raw input is recorded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Device {
    /// HDL-32E data packets (UDP 2368).
    Lidar,
    /// HDL-32E position packets (UDP 8308): GPS time and NMEA.
    LidarPosition,
    /// Xsens MTi serial bytes.
    Imu,
    /// CAN frames from the motor drives, in SocketCAN's 16-byte layout.
    Can,
}

impl Device {
    pub const ALL: [Device; 4] = [
        Device::Lidar,
        Device::LidarPosition,
        Device::Imu,
        Device::Can,
    ];

    pub fn name(&self) -> &'static str {
        match self {
            Device::Lidar => "lidar",
            Device::LidarPosition => "lidar_position",
            Device::Imu => "imu",
            Device::Can => "can",
        }
    }

    pub fn from_name(s: &str) -> Option<Device> {
        Device::ALL.into_iter().find(|d| d.name() == s)
    }
}

/// Receives raw inputs as they are read: the device, the receive time in
/// nanoseconds since start, and the bytes exactly as received.
pub trait InputSink {
    fn input(&mut self, device: Device, receive_time_ns: u64, bytes: &[u8]);
}

#[derive(Debug, Error)]
pub enum HalError {
    #[error("{device}: {source}")]
    Io {
        device: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Config(String),
    #[error("CAN transmit queue full")]
    TxFull,
    /// The CAN controller left the bus after too many errors; it neither
    /// sends nor receives until it has recovered.
    #[error("CAN controller is bus-off")]
    BusOff,
}

/// Where receive times come from. Every receive time is in the executive's
/// time base: nanoseconds since the hardware was opened (the real rover), or
/// virtual time (sim and replay, whose backends stamp inputs themselves).
pub trait TimeSource: Send + Sync {
    fn now_ns(&self) -> u64;
}

/// A LiDAR packet source (one UDP datagram per input).
pub trait LidarSource {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError>;
}

/// The IMU's serial line: bytes in, configuration bytes out.
pub trait ImuPort {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError>;
    fn write(&mut self, bytes: &[u8]) -> Result<(), HalError>;
}

/// The CAN bus the four motor drives are on: wheel velocity commands go out
/// as CiA 402 PDOs; position, velocity and status come back the same way.
pub trait CanBus {
    fn poll(&mut self, now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError>;
    fn send(&mut self, now_ns: u64, frame: &CanFrame) -> Result<(), HalError>;
    /// Received input the transport could not make into frames and dropped
    /// so far (an slcan adapter's bad lines); frames reach the drivers whole.
    fn dropped_input(&self) -> u64 {
        0
    }
}

/// The whole rover as seen by the on-board software.
pub trait Hardware {
    /// Bring the hardware up to time `now_ns` (the start of a minor frame).
    /// Simulated hardware integrates its physics here; real and replayed
    /// hardware have nothing to do.
    fn advance_to(&mut self, _now_ns: u64) {}
    /// The commands for this frame have all been sent and its inputs
    /// collected: nothing the software does can change the world before
    /// `next_ns`, the next frame's start. Simulated hardware may compute
    /// that stretch now, beside the frame's tasks, and must give exactly
    /// what `advance_to(next_ns)` alone would. Inputs stay unseen until
    /// polled after `advance_to`.
    fn look_ahead(&mut self, _next_ns: u64) {}
    /// Simulated hardware whose rover can do nothing more (wrecked in a
    /// fall): the mission ends. Real and replayed hardware never are.
    fn world_over(&self) -> bool {
        false
    }
    /// The executive's frame 0 starts now: receive times count from here,
    /// so that they and the frames share one time base (on hardware whose
    /// time passes on its own; sim and replay stamp inputs in frame time).
    fn start_receive_clock(&mut self) {}
    /// Now, in the time base of the receive times, on hardware whose time
    /// passes on its own (the real rover); none where the executive's
    /// frames make the time (sim, replay).
    fn receive_clock_ns(&self) -> Option<u64> {
        None
    }
    fn lidar(&mut self) -> &mut dyn LidarSource;
    fn imu(&mut self) -> &mut dyn ImuPort;
    fn can(&mut self) -> &mut dyn CanBus;
}
