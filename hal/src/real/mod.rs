//! Transports to the real devices.

pub mod udp_lidar;
