//! Classic CAN frames and their SocketCAN wire layout.

/// A classic CAN frame (11-bit or 29-bit identifier, up to 8 data bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct CanFrame {
    /// Identifier without flag bits.
    pub id: u32,
    pub extended: bool,
    pub rtr: bool,
    pub len: u8,
    pub data: [u8; 8],
}

/// Size of `struct can_frame` as read from a SocketCAN raw socket.
pub const SOCKETCAN_FRAME_LEN: usize = 16;

const EFF_FLAG: u32 = 0x8000_0000;
const RTR_FLAG: u32 = 0x4000_0000;
const ERR_FLAG: u32 = 0x2000_0000;

/// Why bytes are not a CAN frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CanDecodeError {
    WrongLength(usize),
    BadDlc(u8),
    ErrorFrame,
    BadStandardId(u32),
}

impl CanFrame {
    /// A standard-identifier data frame. Data longer than 8 bytes is cut.
    pub fn new(id: u16, data: &[u8]) -> Self {
        let n = data.len().min(8);
        let mut d = [0u8; 8];
        d[..n].copy_from_slice(&data[..n]);
        CanFrame {
            id: id as u32 & 0x7ff,
            extended: false,
            rtr: false,
            len: n as u8,
            data: d,
        }
    }

    pub fn payload(&self) -> &[u8] {
        &self.data[..self.len.min(8) as usize]
    }

    /// SocketCAN's `struct can_frame`: `can_id` (host order, little-endian on
    /// the targets we run), `len`, three padding bytes, eight data bytes.
    pub fn to_socketcan(&self) -> [u8; SOCKETCAN_FRAME_LEN] {
        let mut id = self.id;
        if self.extended {
            id |= EFF_FLAG;
        }
        if self.rtr {
            id |= RTR_FLAG;
        }
        let mut out = [0u8; SOCKETCAN_FRAME_LEN];
        out[..4].copy_from_slice(&id.to_le_bytes());
        out[4] = self.len;
        out[8..].copy_from_slice(&self.data);
        out
    }

    pub fn from_socketcan(b: &[u8]) -> Result<CanFrame, CanDecodeError> {
        if b.len() != SOCKETCAN_FRAME_LEN {
            return Err(CanDecodeError::WrongLength(b.len()));
        }
        let raw = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        if raw & ERR_FLAG != 0 {
            return Err(CanDecodeError::ErrorFrame);
        }
        let extended = raw & EFF_FLAG != 0;
        let id = raw & 0x1fff_ffff;
        if !extended && id > 0x7ff {
            return Err(CanDecodeError::BadStandardId(id));
        }
        let len = b[4];
        if len > 8 {
            return Err(CanDecodeError::BadDlc(len));
        }
        let mut data = [0u8; 8];
        data.copy_from_slice(&b[8..16]);
        Ok(CanFrame {
            id,
            extended,
            rtr: raw & RTR_FLAG != 0,
            len,
            data,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn socketcan_round_trip() {
        let f = CanFrame::new(0x182, &[0x37, 0x06, 1, 2, 3, 4]);
        let b = f.to_socketcan();
        assert_eq!(&b[..5], &[0x82, 0x01, 0, 0, 6]);
        assert_eq!(CanFrame::from_socketcan(&b), Ok(f));
    }

    #[test]
    fn malformed_frames_are_refused() {
        assert_eq!(
            CanFrame::from_socketcan(&[0; 15]),
            Err(CanDecodeError::WrongLength(15))
        );
        let mut b = CanFrame::new(1, &[]).to_socketcan();
        b[4] = 9;
        assert_eq!(CanFrame::from_socketcan(&b), Err(CanDecodeError::BadDlc(9)));
        let mut e = [0u8; 16];
        e[3] = 0x20;
        assert_eq!(
            CanFrame::from_socketcan(&e),
            Err(CanDecodeError::ErrorFrame)
        );
        let mut s = [0u8; 16];
        s[..4].copy_from_slice(&0x800u32.to_le_bytes());
        assert_eq!(
            CanFrame::from_socketcan(&s),
            Err(CanDecodeError::BadStandardId(0x800))
        );
    }
}
