//! CANopen (CiA 301) on the drives' bus: NMT, SYNC, EMCY, heartbeat and
//! expedited SDO, plus the CiA 402 PDOs of [`crate::cia402`].
//!
//! COB-IDs follow the predefined connection set: NMT 0x000, SYNC 0x080,
//! EMCY 0x080 + node, PDOs 0x180..0x57F, SDO server->client 0x580 + node,
//! client->server 0x600 + node, heartbeat 0x700 + node.

pub mod candump;
pub mod sdo;
pub mod supervisor;

use crate::can::CanFrame;
use crate::cia402::{self, Pdo, PdoError};

pub use sdo::Sdo;

pub const NMT_ID: u16 = 0x000;
pub const EMCY_BASE: u16 = 0x080;
pub const SDO_TX_BASE: u16 = 0x580;
pub const SDO_RX_BASE: u16 = 0x600;
pub const HEARTBEAT_BASE: u16 = 0x700;

/// NMT commands (byte 0 of an NMT frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmtCommand {
    Start,
    Stop,
    EnterPreOperational,
    ResetNode,
    ResetCommunication,
}

impl NmtCommand {
    pub fn code(self) -> u8 {
        match self {
            NmtCommand::Start => 0x01,
            NmtCommand::Stop => 0x02,
            NmtCommand::EnterPreOperational => 0x80,
            NmtCommand::ResetNode => 0x81,
            NmtCommand::ResetCommunication => 0x82,
        }
    }

    pub fn from_code(c: u8) -> Option<Self> {
        Some(match c {
            0x01 => NmtCommand::Start,
            0x02 => NmtCommand::Stop,
            0x80 => NmtCommand::EnterPreOperational,
            0x81 => NmtCommand::ResetNode,
            0x82 => NmtCommand::ResetCommunication,
            _ => return None,
        })
    }
}

/// NMT states reported by heartbeats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmtState {
    BootUp,
    Stopped,
    Operational,
    PreOperational,
}

impl NmtState {
    pub fn code(self) -> u8 {
        match self {
            NmtState::BootUp => 0x00,
            NmtState::Stopped => 0x04,
            NmtState::Operational => 0x05,
            NmtState::PreOperational => 0x7F,
        }
    }

    pub fn from_code(c: u8) -> Option<Self> {
        Some(match c & 0x7F {
            0x00 => NmtState::BootUp,
            0x04 => NmtState::Stopped,
            0x05 => NmtState::Operational,
            0x7F => NmtState::PreOperational,
            _ => return None,
        })
    }
}

/// One frame, as the protocol sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    Nmt {
        command: NmtCommand,
        node: u8,
    },
    Sync,
    Emcy {
        node: u8,
        code: u16,
        register: u8,
    },
    Heartbeat {
        node: u8,
        state: NmtState,
    },
    /// A PDO of Speleo's CiA 402 mapping.
    Pdo(Pdo),
    SdoRequest {
        node: u8,
        sdo: Sdo,
    },
    SdoResponse {
        node: u8,
        sdo: Sdo,
    },
    /// Well-formed CAN traffic outside the above (other PDOs, time stamps).
    Other {
        id: u32,
    },
    /// A frame of a known kind with the wrong length or content.
    Malformed {
        id: u32,
        len: u8,
    },
}

pub fn nmt(command: NmtCommand, node: u8) -> CanFrame {
    CanFrame::new(NMT_ID, &[command.code(), node])
}

pub fn heartbeat(node: u8, state: NmtState) -> CanFrame {
    CanFrame::new(HEARTBEAT_BASE + node as u16, &[state.code()])
}

pub fn emcy(node: u8, code: u16, register: u8) -> CanFrame {
    let c = code.to_le_bytes();
    CanFrame::new(
        EMCY_BASE + node as u16,
        &[c[0], c[1], register, 0, 0, 0, 0, 0],
    )
}

/// What a frame is.
pub fn classify(f: &CanFrame) -> Event {
    let malformed = Event::Malformed {
        id: f.id,
        len: f.len,
    };
    if f.extended || f.rtr {
        return Event::Other { id: f.id };
    }
    let id = f.id as u16;
    let p = f.payload();
    let node = (id & 0x7F) as u8;
    match id {
        NMT_ID => match p {
            [c, n] => match NmtCommand::from_code(*c) {
                Some(command) => Event::Nmt { command, node: *n },
                None => malformed,
            },
            _ => malformed,
        },
        cia402::SYNC_ID => match p {
            [] | [_] => Event::Sync,
            _ => malformed,
        },
        0x081..=0x0FF => match p {
            [a, b, r, ..] if p.len() == 8 => Event::Emcy {
                node,
                code: u16::from_le_bytes([*a, *b]),
                register: *r,
            },
            _ => malformed,
        },
        0x701..=0x77F => match p {
            [s] => match NmtState::from_code(*s) {
                Some(state) => Event::Heartbeat { node, state },
                None => malformed,
            },
            _ => malformed,
        },
        0x581..=0x5FF => match Sdo::parse_response(p) {
            Some(sdo) => Event::SdoResponse { node, sdo },
            None => malformed,
        },
        0x601..=0x67F => match Sdo::parse_request(p) {
            Some(sdo) => Event::SdoRequest { node, sdo },
            None => malformed,
        },
        _ => match cia402::decode(f) {
            Ok(pdo) => Event::Pdo(pdo),
            Err(PdoError::Unmapped) => Event::Other { id: f.id },
            Err(PdoError::WrongLength { .. }) => malformed,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn protocol_frames_round_trip() {
        assert_eq!(
            classify(&nmt(NmtCommand::Start, 0)),
            Event::Nmt {
                command: NmtCommand::Start,
                node: 0
            }
        );
        assert_eq!(
            classify(&heartbeat(3, NmtState::Operational)),
            Event::Heartbeat {
                node: 3,
                state: NmtState::Operational
            }
        );
        assert_eq!(
            classify(&emcy(2, 0x2310, 0x03)),
            Event::Emcy {
                node: 2,
                code: 0x2310,
                register: 3
            }
        );
        assert_eq!(classify(&cia402::sync()), Event::Sync);
        assert!(matches!(
            classify(&CanFrame::new(0x702, &[0x42])),
            Event::Malformed { .. }
        ));
        assert!(matches!(
            classify(&CanFrame::new(0x000, &[0x01])),
            Event::Malformed { .. }
        ));
    }
}
