//! HDL-32E data packets from a UDP socket.

use std::io::ErrorKind;
use std::net::{SocketAddr, UdpSocket};

use crate::{Device, HalError, InputSink, LidarSource};

/// Largest datagram accepted; HDL-32E data packets are 1206 bytes.
const MAX_DATAGRAM: usize = 1500;
/// At most this many datagrams per poll, so one frame cannot be flooded.
const MAX_PER_POLL: usize = 256;

/// Non-blocking UDP sockets (data, and optionally position packets) that
/// accept datagrams only from the configured sensor's IP address.
pub struct UdpLidar {
    socket: UdpSocket,
    /// Position packets (UDP 8308), when bound.
    position: Option<UdpSocket>,
    sensor: SocketAddr,
    buf: Box<[u8; MAX_DATAGRAM]>,
    /// Datagrams from other senders.
    pub foreign: u64,
    /// Datagrams dropped because the per-poll limit was reached were left in
    /// the socket buffer; this counts polls that hit the limit.
    pub saturated_polls: u64,
    time: std::sync::Arc<dyn crate::TimeSource>,
}

impl UdpLidar {
    /// Bind `local` (e.g. `0.0.0.0:2368`) and accept only datagrams from the
    /// IP address of `sensor` (its data and position packets leave from
    /// different ports).
    /// `time` stamps each datagram on receipt.
    pub fn bind(
        local: SocketAddr,
        sensor: SocketAddr,
        time: std::sync::Arc<dyn crate::TimeSource>,
    ) -> Result<Self, HalError> {
        let io = |source| HalError::Io {
            device: "lidar",
            source,
        };
        let socket = UdpSocket::bind(local).map_err(io)?;
        socket.set_nonblocking(true).map_err(io)?;
        Ok(UdpLidar {
            socket,
            position: None,
            sensor,
            buf: Box::new([0; MAX_DATAGRAM]),
            foreign: 0,
            saturated_polls: 0,
            time,
        })
    }

    /// Also receive the sensor's position packets on `local`.
    pub fn with_position(mut self, local: SocketAddr) -> Result<Self, HalError> {
        let io = |source| HalError::Io {
            device: "lidar_position",
            source,
        };
        let s = UdpSocket::bind(local).map_err(io)?;
        s.set_nonblocking(true).map_err(io)?;
        self.position = Some(s);
        Ok(self)
    }

    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.socket.local_addr().ok()
    }
}

impl UdpLidar {
    fn drain(&mut self, position: bool, sink: &mut dyn InputSink) -> Result<(), HalError> {
        let (socket, device) = match (&self.position, position) {
            (Some(p), true) => (p, Device::LidarPosition),
            (None, true) => return Ok(()),
            _ => (&self.socket, Device::Lidar),
        };
        for _ in 0..MAX_PER_POLL {
            match socket.recv_from(&mut self.buf[..]) {
                Ok((n, from)) => {
                    if from.ip() != self.sensor.ip() {
                        self.foreign += 1;
                        continue;
                    }
                    sink.input(device, self.time.now_ns(), &self.buf[..n]);
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => return Ok(()),
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(source) => {
                    return Err(HalError::Io {
                        device: "lidar",
                        source,
                    })
                }
            }
        }
        self.saturated_polls += 1;
        Ok(())
    }
}

impl LidarSource for UdpLidar {
    fn poll(&mut self, _now_ns: u64, sink: &mut dyn InputSink) -> Result<(), HalError> {
        self.drain(false, sink)?;
        self.drain(true, sink)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Collect(Vec<Vec<u8>>);
    impl InputSink for Collect {
        fn input(&mut self, _d: Device, _t: u64, bytes: &[u8]) {
            self.0.push(bytes.to_vec());
        }
    }

    #[test]
    fn only_the_sensor_is_heard() {
        let sensor = UdpSocket::bind("127.0.0.1:0").expect("bind sensor");
        // Another host: any other address of the loopback range.
        let stranger = UdpSocket::bind("127.0.0.2:0").expect("bind stranger");
        let mut lidar = UdpLidar::bind(
            "127.0.0.1:0".parse().expect("addr"),
            sensor.local_addr().expect("addr"),
            std::sync::Arc::new(crate::real::FixedTime(7)),
        )
        .expect("bind");
        let to = lidar.local_addr().expect("addr");
        sensor.send_to(&[1u8; 1206], to).expect("send");
        stranger.send_to(&[2u8; 1206], to).expect("send");
        sensor.send_to(&[3u8; 10], to).expect("send");
        std::thread::sleep(std::time::Duration::from_millis(50));
        let mut c = Collect(Vec::new());
        lidar.poll(0, &mut c).expect("poll");
        assert_eq!(c.0.len(), 2);
        assert_eq!(c.0[0].len(), 1206);
        assert_eq!(c.0[1], vec![3u8; 10]);
        assert_eq!(lidar.foreign, 1);
    }
}
