//! Position packets (UDP 8308): the sensor's GPS time and NMEA sentence.

use super::POSITION_PACKET_LEN;

/// Offsets in the 512-byte packet (HDL-32E user manual, appendix E).
const TIMESTAMP_AT: usize = 198;
const NMEA_AT: usize = 206;
const NMEA_LEN: usize = 72;

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PositionPacket {
    /// Microseconds past the hour.
    pub timestamp_us: u32,
    /// The NMEA sentence ($GPRMC), without trailing NULs and line ends;
    /// bytes that are not printable ASCII are left out.
    pub nmea: heapless::String<NMEA_LEN>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PositionError {
    WrongLength(usize),
}

impl core::fmt::Display for PositionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PositionError::WrongLength(n) => {
                write!(f, "position packet of {n} bytes (expected 512)")
            }
        }
    }
}

impl PositionPacket {
    pub fn parse(b: &[u8]) -> Result<PositionPacket, PositionError> {
        if b.len() != POSITION_PACKET_LEN {
            return Err(PositionError::WrongLength(b.len()));
        }
        let ts = u32::from_le_bytes([
            b[TIMESTAMP_AT],
            b[TIMESTAMP_AT + 1],
            b[TIMESTAMP_AT + 2],
            b[TIMESTAMP_AT + 3],
        ]);
        let raw = &b[NMEA_AT..NMEA_AT + NMEA_LEN];
        let end = raw.iter().position(|&c| c == 0).unwrap_or(raw.len());
        let mut nmea = heapless::String::new();
        for &c in &raw[..end] {
            if (0x20..0x7F).contains(&c) {
                let _ = nmea.push(c as char);
            }
        }
        Ok(PositionPacket {
            timestamp_us: ts,
            nmea,
        })
    }
}
