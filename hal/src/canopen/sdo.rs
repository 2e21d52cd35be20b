//! Expedited SDO (up to 4 data bytes), client and server sides.

use crate::can::CanFrame;

use super::{SDO_RX_BASE, SDO_TX_BASE};

/// One expedited SDO message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sdo {
    /// Client asks to read `index:sub`.
    UploadRequest { index: u16, sub: u8 },
    /// Server answers with `len` (1 to 4) bytes of `value` (little-endian).
    UploadResponse {
        index: u16,
        sub: u8,
        value: u32,
        len: u8,
    },
    /// Client writes `len` bytes of `value`.
    DownloadRequest {
        index: u16,
        sub: u8,
        value: u32,
        len: u8,
    },
    /// Server confirms the write.
    DownloadResponse { index: u16, sub: u8 },
    /// Either side aborts with a CiA 301 abort code.
    Abort { index: u16, sub: u8, code: u32 },
}

/// Abort codes used here.
pub const ABORT_NO_OBJECT: u32 = 0x0602_0000;
pub const ABORT_READ_ONLY: u32 = 0x0601_0002;
pub const ABORT_VALUE_RANGE: u32 = 0x0609_0030;
pub const ABORT_TIMEOUT: u32 = 0x0504_0000;
pub const ABORT_UNSUPPORTED: u32 = 0x0504_0001;

pub fn abort_text(code: u32) -> &'static str {
    match code {
        ABORT_NO_OBJECT => "object does not exist",
        ABORT_READ_ONLY => "attempt to write a read-only object",
        ABORT_VALUE_RANGE => "value range exceeded",
        ABORT_TIMEOUT => "SDO protocol timed out",
        ABORT_UNSUPPORTED => "command specifier not valid or unknown",
        0x0601_0000 => "unsupported access to an object",
        0x0607_0010 => "data type does not match, length does not match",
        0x0800_0000 => "general error",
        0x0800_0022 => "data cannot be transferred because of the present device state",
        _ => "abort",
    }
}

fn mux(p: &[u8]) -> (u16, u8) {
    (u16::from_le_bytes([p[1], p[2]]), p[3])
}

fn value(p: &[u8]) -> u32 {
    u32::from_le_bytes([p[4], p[5], p[6], p[7]])
}

/// Bytes used of an expedited transfer with size indicated.
fn expedited_len(cs: u8) -> u8 {
    if cs & 0x01 != 0 {
        4 - ((cs >> 2) & 0x03)
    } else {
        4
    }
}

fn mask(v: u32, len: u8) -> u32 {
    if len >= 4 {
        v
    } else {
        v & ((1u32 << (8 * len as u32)) - 1)
    }
}

impl Sdo {
    /// A client-to-server message (0x600 + node).
    pub fn parse_request(p: &[u8]) -> Option<Sdo> {
        if p.len() != 8 {
            return None;
        }
        let (index, sub) = mux(p);
        let cs = p[0];
        match cs >> 5 {
            2 => Some(Sdo::UploadRequest { index, sub }),
            1 if cs & 0x02 != 0 => {
                let len = expedited_len(cs);
                Some(Sdo::DownloadRequest {
                    index,
                    sub,
                    value: mask(value(p), len),
                    len,
                })
            }
            4 => Some(Sdo::Abort {
                index,
                sub,
                code: value(p),
            }),
            _ => None,
        }
    }

    /// A server-to-client message (0x580 + node).
    pub fn parse_response(p: &[u8]) -> Option<Sdo> {
        if p.len() != 8 {
            return None;
        }
        let (index, sub) = mux(p);
        let cs = p[0];
        match cs >> 5 {
            2 if cs & 0x02 != 0 => {
                let len = expedited_len(cs);
                Some(Sdo::UploadResponse {
                    index,
                    sub,
                    value: mask(value(p), len),
                    len,
                })
            }
            3 => Some(Sdo::DownloadResponse { index, sub }),
            4 => Some(Sdo::Abort {
                index,
                sub,
                code: value(p),
            }),
            _ => None,
        }
    }

    fn bytes(&self) -> [u8; 8] {
        let (cs, index, sub, v) = match *self {
            Sdo::UploadRequest { index, sub } => (0x40, index, sub, 0),
            Sdo::UploadResponse {
                index,
                sub,
                value,
                len,
            } => (0x43 | ((4 - len.clamp(1, 4)) << 2), index, sub, value),
            Sdo::DownloadRequest {
                index,
                sub,
                value,
                len,
            } => (0x23 | ((4 - len.clamp(1, 4)) << 2), index, sub, value),
            Sdo::DownloadResponse { index, sub } => (0x60, index, sub, 0),
            Sdo::Abort { index, sub, code } => (0x80, index, sub, code),
        };
        let i = index.to_le_bytes();
        let d = v.to_le_bytes();
        [cs, i[0], i[1], sub, d[0], d[1], d[2], d[3]]
    }

    /// The frame a client sends to `node`.
    pub fn request(&self, node: u8) -> CanFrame {
        CanFrame::new(SDO_RX_BASE + node as u16, &self.bytes())
    }

    /// The frame server `node` sends.
    pub fn response(&self, node: u8) -> CanFrame {
        CanFrame::new(SDO_TX_BASE + node as u16, &self.bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_captured_device_type_read_decodes() {
        // candump from a boot-up (../shared/data/can): 602#4000100000000000, 582#4300100092010200.
        assert_eq!(
            Sdo::parse_request(&[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]),
            Some(Sdo::UploadRequest {
                index: 0x1000,
                sub: 0
            })
        );
        assert_eq!(
            Sdo::parse_response(&[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]),
            Some(Sdo::UploadResponse {
                index: 0x1000,
                sub: 0,
                value: 0x0002_0192,
                len: 4
            })
        );
        // 2B 40 60 00 00 01: write controlword 0x0100 (two bytes); 60 40 60 00: done.
        assert_eq!(
            Sdo::parse_request(&[0x2B, 0x40, 0x60, 0x00, 0x00, 0x01, 0x00, 0x00]),
            Some(Sdo::DownloadRequest {
                index: 0x6040,
                sub: 0,
                value: 0x0100,
                len: 2
            })
        );
        // maxon EPOS: 582 | 4B 41 60 00 37 07 -> statusword 0x0737.
        assert_eq!(
            Sdo::parse_response(&[0x4B, 0x41, 0x60, 0x00, 0x37, 0x07, 0, 0]),
            Some(Sdo::UploadResponse {
                index: 0x6041,
                sub: 0,
                value: 0x0737,
                len: 2
            })
        );
    }

    #[test]
    fn messages_round_trip() {
        for s in [
            Sdo::UploadRequest {
                index: 0x6041,
                sub: 0,
            },
            Sdo::DownloadRequest {
                index: 0x6060,
                sub: 0,
                value: 3,
                len: 1,
            },
            Sdo::Abort {
                index: 0x1234,
                sub: 5,
                code: ABORT_NO_OBJECT,
            },
        ] {
            assert_eq!(Sdo::parse_request(s.request(2).payload()), Some(s));
        }
        for s in [
            Sdo::UploadResponse {
                index: 0x1017,
                sub: 0,
                value: 100,
                len: 2,
            },
            Sdo::DownloadResponse {
                index: 0x6060,
                sub: 0,
            },
        ] {
            assert_eq!(Sdo::parse_response(s.response(2).payload()), Some(s));
        }
        assert_eq!(Sdo::parse_request(&[0x40, 0, 0]), None);
    }
}
