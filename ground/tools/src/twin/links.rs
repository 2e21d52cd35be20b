//! The twin's wires to the flight binary: the HDL-32E's UDP packets, the
//! MTi's serial line and an slcan adapter in front of the drives' CAN bus.
//! Device output from the simulated hardware goes out on them; what the
//! flight binary writes comes back to the simulated devices.

use std::net::{SocketAddr, UdpSocket};

use speleo_hal::can::CanFrame;
use speleo_hal::slcan::encode_frame;
use speleo_hal::slcan_adapter::Adapter;
use speleo_hal::{Device, Hardware, InputSink};

use super::serial_end::{SerialEnd, SerialSetting};
use super::tape::{Tape, Track};

/// Where the twin's wires go.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LinkSettings {
    /// The sensor's own address: packets leave from it (the flight binary
    /// accepts only its IP address).
    pub lidar_from: SocketAddr,
    /// Where data packets go (the flight binary's `lidar_bind`).
    pub lidar_to: SocketAddr,
    /// Where position packets go (its `lidar_position_bind`); none: not sent.
    pub lidar_position_to: Option<SocketAddr>,
    pub imu: SerialSetting,
    /// The slcan adapter's serial line.
    pub can: SerialSetting,
}

/// What went over the wires, and what could not.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct LinkCounters {
    pub lidar_packets_sent: u64,
    pub lidar_position_packets_sent: u64,
    /// Packets not sent: the LiDAR was unplugged.
    pub lidar_packets_unplugged: u64,
    /// Packets the socket refused (nobody listening, buffer full).
    pub lidar_send_errors: u64,
    pub imu_bytes_sent: u64,
    /// Bytes the serial line did not take (the flight binary not reading).
    pub imu_bytes_dropped: u64,
    pub imu_bytes_received: u64,
    pub can_frames_to_host: u64,
    /// Frames from the drives not forwarded: the adapter's channel closed.
    pub can_frames_while_closed: u64,
    pub can_bytes_dropped: u64,
    pub can_frames_from_host: u64,
    /// Lines from the host the adapter refused.
    pub can_lines_refused: u64,
}

pub struct Links {
    udp: UdpSocket,
    lidar_to: SocketAddr,
    lidar_position_to: Option<SocketAddr>,
    imu: SerialEnd,
    can: SerialEnd,
    adapter: Adapter,
    lidar_unplugged: bool,
    buf: Box<[u8; 4096]>,
    pub counters: LinkCounters,
    pub tape: Option<Tape>,
    /// Twin time of the device output being delivered.
    now_ns: u64,
}

impl Links {
    /// Open every wire; the error names the one that failed.
    pub fn open(s: &LinkSettings) -> Result<Links, String> {
        let udp = UdpSocket::bind(s.lidar_from)
            .map_err(|e| format!("lidar_from {}: {e}", s.lidar_from))?;
        udp.set_nonblocking(true)
            .map_err(|e| format!("lidar_from {}: {e}", s.lidar_from))?;
        let imu = SerialEnd::open(&s.imu).map_err(|e| format!("imu: {e}"))?;
        let can = SerialEnd::open(&s.can).map_err(|e| format!("can: {e}"))?;
        Ok(Links {
            udp,
            lidar_to: s.lidar_to,
            lidar_position_to: s.lidar_position_to,
            imu,
            can,
            adapter: Adapter::new(),
            lidar_unplugged: false,
            buf: Box::new([0; 4096]),
            counters: LinkCounters::default(),
            tape: None,
            now_ns: 0,
        })
    }

    /// The serial ports the flight binary opens: the MTi's, the adapter's.
    pub fn port_paths(&self) -> (&str, &str) {
        (self.imu.port_path(), self.can.port_path())
    }

    /// Unplug or plug in the LiDAR: unplugged, it sends nothing.
    pub fn set_lidar_unplugged(&mut self, unplugged: bool) {
        self.lidar_unplugged = unplugged;
    }

    /// Whether the flight binary has set up and opened the adapter.
    pub fn can_open(&self) -> bool {
        self.adapter.is_open()
    }

    /// Hand the simulated devices' output due by `now_ns` to the wires.
    pub fn deliver(&mut self, hw: &mut dyn Hardware, now_ns: u64) -> Result<(), String> {
        self.now_ns = now_ns;
        hw.lidar().poll(now_ns, self).map_err(|e| e.to_string())?;
        hw.imu().poll(now_ns, self).map_err(|e| e.to_string())?;
        hw.can().poll(now_ns, self).map_err(|e| e.to_string())?;
        Ok(())
    }

    /// Take what the flight binary wrote to the MTi and to the adapter to
    /// the simulated devices; answer the adapter's commands.
    pub fn collect(&mut self, hw: &mut dyn Hardware, now_ns: u64) -> Result<(), String> {
        loop {
            let n = self
                .imu
                .read(&mut self.buf[..])
                .map_err(|e| format!("imu: {e}"))?;
            if n == 0 {
                break;
            }
            self.counters.imu_bytes_received += n as u64;
            if let Some(t) = &mut self.tape {
                t.raw(Track::ImuReceived, now_ns, &self.buf[..n]);
            }
            hw.imu().write(&self.buf[..n]).map_err(|e| e.to_string())?;
        }
        loop {
            let n = self
                .can
                .read(&mut self.buf[..])
                .map_err(|e| format!("can: {e}"))?;
            if n == 0 {
                break;
            }
            if let Some(t) = &mut self.tape {
                t.raw(Track::CanReceived, now_ns, &self.buf[..n]);
            }
            let mut frames: Vec<CanFrame> = Vec::new();
            let mut answers: Vec<u8> = Vec::new();
            let refused = self.adapter.refused;
            self.adapter.feed(
                &self.buf[..n],
                |f| frames.push(f),
                |a| answers.extend_from_slice(a),
            );
            self.counters.can_lines_refused += self.adapter.refused - refused;
            self.counters.can_frames_from_host += frames.len() as u64;
            for f in &frames {
                hw.can().send(now_ns, f).map_err(|e| e.to_string())?;
            }
            self.write_can(&answers)?;
        }
        Ok(())
    }

    fn write_can(&mut self, bytes: &[u8]) -> Result<(), String> {
        if bytes.is_empty() {
            return Ok(());
        }
        let n = self.can.write(bytes).map_err(|e| format!("can: {e}"))?;
        self.counters.can_bytes_dropped += (bytes.len() - n) as u64;
        if let Some(t) = &mut self.tape {
            t.raw(Track::CanSent, self.now_ns, &bytes[..n]);
        }
        Ok(())
    }

    fn send_udp(&mut self, to: SocketAddr, bytes: &[u8], track: Track) -> bool {
        match self.udp.send_to(bytes, to) {
            Ok(_) => {
                if let Some(t) = &mut self.tape {
                    t.raw(track, self.now_ns, bytes);
                }
                true
            }
            Err(_) => {
                self.counters.lidar_send_errors += 1;
                false
            }
        }
    }
}

impl InputSink for Links {
    fn input(&mut self, device: Device, _t: u64, bytes: &[u8]) {
        match device {
            Device::Lidar if self.lidar_unplugged => self.counters.lidar_packets_unplugged += 1,
            Device::Lidar => {
                if self.send_udp(self.lidar_to, bytes, Track::LidarSent) {
                    self.counters.lidar_packets_sent += 1;
                }
            }
            Device::LidarPosition => {
                if let Some(to) = self.lidar_position_to.filter(|_| !self.lidar_unplugged) {
                    if self.send_udp(to, bytes, Track::LidarPositionSent) {
                        self.counters.lidar_position_packets_sent += 1;
                    }
                }
            }
            Device::Imu => {
                let n = self.imu.write(bytes).unwrap_or(0);
                self.counters.imu_bytes_sent += n as u64;
                self.counters.imu_bytes_dropped += (bytes.len() - n) as u64;
                if let Some(t) = &mut self.tape {
                    t.raw(Track::ImuSent, self.now_ns, &bytes[..n]);
                }
            }
            Device::Can => {
                let Ok(f) = CanFrame::from_socketcan(bytes) else {
                    return;
                };
                // A closed adapter passes nothing from the bus to the host.
                if !self.adapter.is_open() {
                    self.counters.can_frames_while_closed += 1;
                    return;
                }
                let (line, n) = encode_frame(&f);
                if self.write_can(&line[..n]).is_ok() {
                    self.counters.can_frames_to_host += 1;
                }
            }
        }
    }
}
