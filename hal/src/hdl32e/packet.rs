//! The 1206-byte data packet, parsed without copying and written back
//! byte for byte.

use super::{BLOCKS, LASERS, PACKET_LEN};

/// Upper block flag: bytes `FF EE` (0xEEFF little-endian).
pub const BLOCK_FLAG: u16 = 0xEEFF;
/// Return-mode factory byte of dual-return packets: blocks come in pairs
/// from the same firing (same azimuth).
pub const DUAL_RETURN: u8 = 0x39;

impl DataPacket {
    /// Blocks per firing: 2 in dual-return mode, else 1.
    pub fn blocks_per_firing(&self) -> usize {
        if self.factory[0] == DUAL_RETURN {
            2
        } else {
            1
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacketError {
    WrongLength(usize),
    /// Block `block` does not start with `FF EE`.
    BadFlag {
        block: usize,
        flag: u16,
    },
    /// Azimuth of block `block` is above 36000 (36000 itself, 360.00 deg,
    /// does occur in real captures and is accepted).
    BadAzimuth {
        block: usize,
        azimuth: u16,
    },
    /// The timestamp is not a time within the hour (>= 3.6e9 us).
    BadTimestamp(u32),
}

impl core::fmt::Display for PacketError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PacketError::WrongLength(n) => write!(f, "data packet of {n} bytes (expected 1206)"),
            PacketError::BadFlag { block, flag } => {
                write!(f, "block {block} flag 0x{flag:04X} (expected 0xEEFF)")
            }
            PacketError::BadAzimuth { block, azimuth } => {
                write!(f, "block {block} azimuth {azimuth} (> 36000)")
            }
            PacketError::BadTimestamp(t) => {
                write!(f, "timestamp {t} us is not within an hour")
            }
        }
    }
}

impl std::error::Error for PacketError {}

/// One firing sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    pub flag: u16,
    /// Hundredths of a degree, 0..=36000.
    pub azimuth: u16,
    /// 2 mm units; 0 = no return.
    pub distance: [u16; LASERS],
    pub intensity: [u8; LASERS],
}

/// A decoded data packet: every field of the wire format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DataPacket {
    pub blocks: [Block; BLOCKS],
    /// Microseconds past the hour (GPS-synchronised when a GPS is attached).
    pub timestamp_us: u32,
    /// Return mode (0x37 strongest, 0x38 last, 0x39 dual) and product id (0x21 HDL-32E).
    pub factory: [u8; 2],
}

#[inline]
fn u16le(b: &[u8], i: usize) -> u16 {
    u16::from_le_bytes([b[i], b[i + 1]])
}

impl DataPacket {
    /// Parse and validate a UDP payload.
    pub fn parse(b: &[u8]) -> Result<DataPacket, PacketError> {
        if b.len() != PACKET_LEN {
            return Err(PacketError::WrongLength(b.len()));
        }
        let empty = Block {
            flag: 0,
            azimuth: 0,
            distance: [0; LASERS],
            intensity: [0; LASERS],
        };
        let mut blocks = [empty; BLOCKS];
        for (k, blk) in blocks.iter_mut().enumerate() {
            let o = k * 100;
            blk.flag = u16le(b, o);
            if blk.flag != BLOCK_FLAG {
                return Err(PacketError::BadFlag {
                    block: k,
                    flag: blk.flag,
                });
            }
            blk.azimuth = u16le(b, o + 2);
            if blk.azimuth > 36000 {
                return Err(PacketError::BadAzimuth {
                    block: k,
                    azimuth: blk.azimuth,
                });
            }
            for l in 0..LASERS {
                let p = o + 4 + 3 * l;
                blk.distance[l] = u16le(b, p);
                blk.intensity[l] = b[p + 2];
            }
        }
        let timestamp_us = u32::from_le_bytes([b[1200], b[1201], b[1202], b[1203]]);
        if timestamp_us >= 3_600_000_000 {
            return Err(PacketError::BadTimestamp(timestamp_us));
        }
        Ok(DataPacket {
            blocks,
            timestamp_us,
            factory: [b[1204], b[1205]],
        })
    }

    /// The wire bytes.
    pub fn write(&self, out: &mut [u8; PACKET_LEN]) {
        for (k, blk) in self.blocks.iter().enumerate() {
            let o = k * 100;
            out[o..o + 2].copy_from_slice(&blk.flag.to_le_bytes());
            out[o + 2..o + 4].copy_from_slice(&blk.azimuth.to_le_bytes());
            for l in 0..LASERS {
                let p = o + 4 + 3 * l;
                out[p..p + 2].copy_from_slice(&blk.distance[l].to_le_bytes());
                out[p + 2] = blk.intensity[l];
            }
        }
        out[1200..1204].copy_from_slice(&self.timestamp_us.to_le_bytes());
        out[1204..1206].copy_from_slice(&self.factory);
    }

    pub fn to_bytes(&self) -> [u8; PACKET_LEN] {
        let mut out = [0u8; PACKET_LEN];
        self.write(&mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> [u8; PACKET_LEN] {
        let mut b = [0u8; PACKET_LEN];
        for k in 0..BLOCKS {
            b[k * 100] = 0xFF;
            b[k * 100 + 1] = 0xEE;
            let az = (k as u16 * 20 + 35990) % 36000;
            b[k * 100 + 2..k * 100 + 4].copy_from_slice(&az.to_le_bytes());
            for l in 0..LASERS {
                b[k * 100 + 4 + 3 * l] = (l * 7 + k) as u8;
                b[k * 100 + 6 + 3 * l] = l as u8;
            }
        }
        b[1200..1204].copy_from_slice(&123_456u32.to_le_bytes());
        b[1204] = 0x37;
        b[1205] = 0x21;
        b
    }

    #[test]
    fn parse_then_write_is_the_identity() {
        let b = sample();
        let p = DataPacket::parse(&b).expect("valid");
        assert_eq!(p.timestamp_us, 123_456);
        assert_eq!(p.blocks[1].azimuth, 10);
        assert_eq!(p.to_bytes(), b);
    }

    #[test]
    fn malformed_packets_are_refused() {
        let b = sample();
        assert_eq!(
            DataPacket::parse(&b[..1205]),
            Err(PacketError::WrongLength(1205))
        );
        let mut f = b;
        f[300] = 0x00;
        assert!(matches!(
            DataPacket::parse(&f),
            Err(PacketError::BadFlag { block: 3, .. })
        ));
        let mut a = b;
        a[2..4].copy_from_slice(&36001u16.to_le_bytes());
        assert!(matches!(
            DataPacket::parse(&a),
            Err(PacketError::BadAzimuth { block: 0, .. })
        ));
    }
}
