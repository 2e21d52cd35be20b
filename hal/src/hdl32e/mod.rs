//! Velodyne HDL-32E: data packets, calibration, point decoding, frame
//! assembly, position packets, and the encoder the simulated LiDAR uses.
//!
//! A data packet (UDP 2368) is 1206 bytes: 12 blocks of 100 bytes (flag
//! `FF EE`, azimuth in 0.01 deg, then 32 returns of distance in 2 mm units
//! and intensity), a GPS timestamp in microseconds past the hour, and two
//! factory bytes (return mode, product id). Each block is one firing sequence
//! of the 32 lasers, 1.152 us apart; blocks are 46.08 us apart.

pub mod calib;
pub mod decode;
pub mod encode;
pub mod frames;
pub mod packet;
pub mod position;

pub use calib::Calibration;
pub use decode::{Decoder, Interpolation, Point};
pub use frames::FrameAssembler;
pub use packet::{Block, DataPacket, PacketError};

pub const LASERS: usize = 32;
pub const BLOCKS: usize = 12;
pub const PACKET_LEN: usize = 1206;
pub const POSITION_PACKET_LEN: usize = 512;
pub const DATA_PORT: u16 = 2368;
pub const POSITION_PORT: u16 = 8308;
/// Time between two lasers of one firing sequence.
pub const LASER_PERIOD_NS: f64 = 1152.0;
/// Time between two firing sequences (blocks).
pub const BLOCK_PERIOD_NS: f64 = 46080.0;
