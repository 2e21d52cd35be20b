//! Position packets (UDP 8308): the sensor's GPS time and NMEA sentence.

use super::POSITION_PACKET_LEN;

/// Offsets in the 512-byte packet (HDL-32E user manual, appendix E).
const TIMESTAMP_AT: usize = 198;
const NMEA_AT: usize = 206;
const NMEA_LEN: usize = 72;
/// Time between two position packets: the sensor sends about 200 a second
/// whether or not a GPS receiver is connected.
pub const POSITION_PERIOD_NS: u64 = 5_000_000;

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
    /// The 512 bytes on the wire: the timestamp and the sentence at their
    /// offsets; the gyro, temperature and accelerometer fields and the
    /// unused bytes zero.
    pub fn to_bytes(&self) -> [u8; POSITION_PACKET_LEN] {
        let mut b = [0u8; POSITION_PACKET_LEN];
        b[TIMESTAMP_AT..TIMESTAMP_AT + 4].copy_from_slice(&self.timestamp_us.to_le_bytes());
        let n = self.nmea.len();
        b[NMEA_AT..NMEA_AT + n].copy_from_slice(self.nmea.as_bytes());
        b
    }

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_packet_reads_back_as_it_was_written() {
        let mut nmea = heapless::String::new();
        let _ = nmea
            .push_str("$GPRMC,220632,A,3707.8324,N,12139.2864,W,000.0,144.7,111212,013.8,E,D*09");
        let p = PositionPacket {
            timestamp_us: 3_599_999_999,
            nmea,
        };
        let b = p.to_bytes();
        assert_eq!(b.len(), POSITION_PACKET_LEN);
        assert_eq!(PositionPacket::parse(&b), Ok(p));
    }

    #[test]
    fn without_a_receiver_the_sentence_is_empty() {
        let p = PositionPacket {
            timestamp_us: 5_000,
            nmea: heapless::String::new(),
        };
        let back = PositionPacket::parse(&p.to_bytes()).expect("512 bytes");
        assert_eq!(back.timestamp_us, 5_000);
        assert!(back.nmea.is_empty());
    }

    #[test]
    fn other_lengths_are_refused_with_theirs() {
        assert_eq!(
            PositionPacket::parse(&[0; 511]),
            Err(PositionError::WrongLength(511))
        );
    }
}
