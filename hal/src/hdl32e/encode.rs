//! Points and firings back to data packets: the simulated LiDAR's encoder.

use super::calib::Calibration;
use super::decode::Point;
use super::packet::{Block, DataPacket, BLOCK_FLAG};
use super::{BLOCKS, LASERS, PACKET_LEN};

/// Return mode "strongest" and product id HDL-32E.
pub const FACTORY_STRONGEST_HDL32E: [u8; 2] = [0x37, 0x21];

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EncodeError {
    /// A point names a block or laser outside the packet.
    BadIndex { block: u8, laser: u8 },
    /// A distance that the 16-bit field cannot carry.
    OutOfRange { distance_m: f32 },
    /// Two points for the same block and laser.
    Duplicate { block: u8, laser: u8 },
}

/// Raw distance units for a corrected distance of laser `laser`.
fn raw_distance(cal: &Calibration, laser: usize, distance_m: f32) -> Option<u16> {
    let raw =
        ((distance_m as f64 - cal.lasers[laser].dist_correction_m) / cal.distance_lsb_m).round();
    (1.0..=65535.0).contains(&raw).then_some(raw as u16)
}

/// Build the packet whose decoded points are `points` (each naming its block
/// and laser), with the given block azimuths (0.01 deg), timestamp and
/// factory bytes. Lasers without a point get no return; a point at distance
/// 0 is a no-return entry whose intensity is kept (real sensors send one).
pub fn encode_points(
    cal: &Calibration,
    azimuths: &[u16; BLOCKS],
    points: &[Point],
    timestamp_us: u32,
    factory: [u8; 2],
) -> Result<[u8; PACKET_LEN], EncodeError> {
    let mut p = DataPacket {
        blocks: azimuths.map(|azimuth| Block {
            flag: BLOCK_FLAG,
            azimuth: azimuth.min(36000),
            distance: [0; LASERS],
            intensity: [0; LASERS],
        }),
        timestamp_us,
        factory,
    };
    for pt in points {
        let (b, l) = (pt.block as usize, pt.laser as usize);
        if b >= BLOCKS || l >= LASERS {
            return Err(EncodeError::BadIndex {
                block: pt.block,
                laser: pt.laser,
            });
        }
        // A point at distance 0 is a "no return" entry that keeps its intensity.
        let raw = if pt.distance == 0.0 {
            0
        } else {
            raw_distance(cal, l, pt.distance).ok_or(EncodeError::OutOfRange {
                distance_m: pt.distance,
            })?
        };
        let blk = &mut p.blocks[b];
        if blk.distance[l] != 0 || blk.intensity[l] != 0 {
            return Err(EncodeError::Duplicate {
                block: pt.block,
                laser: pt.laser,
            });
        }
        blk.distance[l] = raw;
        blk.intensity[l] = pt.intensity;
    }
    Ok(p.to_bytes())
}

/// One firing sequence as the simulated sensor measures it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Firing {
    /// Azimuth at the first laser, hundredths of a degree.
    pub azimuth: u16,
    /// Corrected distance per laser in metres; 0 or non-finite = no return.
    pub distance_m: [f32; LASERS],
    pub intensity: [u8; LASERS],
}

/// Collects firings into packets of 12 blocks.
pub struct PacketEncoder {
    cal: Calibration,
    packet: DataPacket,
    filled: usize,
    factory: [u8; 2],
    /// Returns too far for the 16-bit field, sent as no return.
    pub out_of_range: u64,
}

impl PacketEncoder {
    pub fn new(cal: Calibration) -> Self {
        let empty = Block {
            flag: BLOCK_FLAG,
            azimuth: 0,
            distance: [0; LASERS],
            intensity: [0; LASERS],
        };
        PacketEncoder {
            cal,
            packet: DataPacket {
                blocks: [empty; BLOCKS],
                timestamp_us: 0,
                factory: FACTORY_STRONGEST_HDL32E,
            },
            filled: 0,
            factory: FACTORY_STRONGEST_HDL32E,
            out_of_range: 0,
        }
    }

    /// Add a firing that started `timestamp_us` past the hour; returns the
    /// packet when this firing completes one.
    pub fn push(&mut self, f: &Firing, timestamp_us: u32) -> Option<[u8; PACKET_LEN]> {
        if self.filled == 0 {
            self.packet.timestamp_us = timestamp_us;
            self.packet.factory = self.factory;
        }
        let blk = &mut self.packet.blocks[self.filled];
        blk.azimuth = f.azimuth % 36000;
        for l in 0..LASERS {
            let d = f.distance_m[l];
            let raw = if d.is_finite() && d > 0.0 {
                match raw_distance(&self.cal, l, d) {
                    Some(r) => r,
                    None => {
                        self.out_of_range += 1;
                        0
                    }
                }
            } else {
                0
            };
            blk.distance[l] = raw;
            blk.intensity[l] = if raw == 0 { 0 } else { f.intensity[l] };
        }
        self.filled += 1;
        if self.filled < BLOCKS {
            return None;
        }
        self.filled = 0;
        Some(self.packet.to_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::super::decode::Decoder;
    use super::*;

    #[test]
    fn firings_round_trip_through_the_decoder() {
        let cal = Calibration::nominal();
        let mut enc = PacketEncoder::new(cal.clone());
        let mut packet = None;
        for b in 0..BLOCKS {
            let mut f = Firing {
                azimuth: (35_990 + 20 * b as u32) as u16 % 36000,
                distance_m: [0.0; LASERS],
                intensity: [0; LASERS],
            };
            f.distance_m[3] = 10.0 + b as f32;
            f.intensity[3] = 50;
            f.distance_m[7] = 200.0; // beyond the 131 m the field can carry
            packet = enc.push(&f, 1000);
        }
        let bytes = packet.expect("12 firings make a packet");
        let p = DataPacket::parse(&bytes).expect("valid");
        assert_eq!(enc.out_of_range, 12);
        let mut n = 0;
        Decoder::new(&cal).decode_with(&p, |pt| {
            assert_eq!(pt.laser, 3);
            assert!((pt.distance - (10.0 + pt.block as f32)).abs() < 0.001);
            n += 1;
        });
        assert_eq!(n, 12);
    }
}
