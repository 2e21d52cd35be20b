//! CiA 402 (CANopen drive profile) in profile velocity mode: the PDO mapping
//! Speleo uses for its four wheel drives, and the statusword states.
//!
//! PDO mapping (node ids 1..=4, the drives' default COB-IDs):
//! - RPDO1 `0x200 + node`: controlword (0x6040, u16) + target velocity (0x60FF, i32)
//! - TPDO1 `0x180 + node`: statusword (0x6041, u16) + velocity actual (0x606C, i32)
//! - TPDO2 `0x280 + node`: position actual (0x6064, i32) + torque actual
//!   (0x6077, i16); a drive that maps position alone sends 4 bytes, and
//!   its torque is unknown
//! - SYNC `0x080`, no data: the drives answer each SYNC with TPDO1 and TPDO2.
//!
//! All values little-endian. Velocities are in milliradians per second at the
//! wheel, positions in encoder increments ([`COUNTS_PER_REV`] per wheel turn),
//! torques in thousandths of the rated torque ([`RATED_TORQUE_MNM`], as the
//! profile has it).

use crate::can::CanFrame;

pub const SYNC_ID: u16 = 0x080;
pub const RPDO1_BASE: u16 = 0x200;
pub const TPDO1_BASE: u16 = 0x180;
pub const TPDO2_BASE: u16 = 0x280;
/// Encoder increments per wheel revolution (after the gearbox).
pub const COUNTS_PER_REV: i64 = 4096 * 4;
/// Rated torque (0x6076) of a wheel drive at the wheel, mN m: torque actual
/// (0x6077) counts thousandths of it.
pub const RATED_TORQUE_MNM: u32 = 15_000;

/// Torque actual (0x6077) in N m at the wheel.
pub fn torque_nm(per_mille: i16) -> f64 {
    per_mille as f64 * RATED_TORQUE_MNM as f64 * 1e-6
}

/// N m at the wheel as torque actual (0x6077), saturated at the field's range.
pub fn torque_per_mille(nm: f64) -> i16 {
    let v = (nm * 1e6 / RATED_TORQUE_MNM as f64).round();
    if v.is_nan() {
        0
    } else {
        v.clamp(i16::MIN as f64, i16::MAX as f64) as i16
    }
}

/// Controlword commands of the state machine.
pub mod controlword {
    pub const SHUTDOWN: u16 = 0x0006;
    pub const SWITCH_ON: u16 = 0x0007;
    pub const ENABLE_OPERATION: u16 = 0x000F;
    pub const DISABLE_VOLTAGE: u16 = 0x0000;
    pub const QUICK_STOP: u16 = 0x0002;
    pub const FAULT_RESET: u16 = 0x0080;
}

/// The drive state encoded in a statusword.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveState {
    NotReadyToSwitchOn,
    SwitchOnDisabled,
    ReadyToSwitchOn,
    SwitchedOn,
    OperationEnabled,
    QuickStopActive,
    FaultReactionActive,
    Fault,
    /// A bit pattern that is no state of the profile.
    Unknown,
}

impl DriveState {
    /// Decode the state bits (0-3, 5, 6) of a statusword.
    pub fn from_statusword(sw: u16) -> DriveState {
        match sw & 0x006F {
            0x0000 | 0x0020 => DriveState::NotReadyToSwitchOn,
            0x0040 | 0x0060 => DriveState::SwitchOnDisabled,
            0x0021 => DriveState::ReadyToSwitchOn,
            0x0023 => DriveState::SwitchedOn,
            0x0027 => DriveState::OperationEnabled,
            0x0007 => DriveState::QuickStopActive,
            0x000F | 0x002F => DriveState::FaultReactionActive,
            0x0008 | 0x0028 => DriveState::Fault,
            _ => DriveState::Unknown,
        }
    }

    /// The statusword a drive reports in this state (voltage enabled, remote).
    pub fn statusword(&self) -> u16 {
        let bits = match self {
            DriveState::NotReadyToSwitchOn => 0x0000,
            DriveState::SwitchOnDisabled => 0x0040,
            DriveState::ReadyToSwitchOn => 0x0021,
            DriveState::SwitchedOn => 0x0023,
            DriveState::OperationEnabled => 0x0027,
            DriveState::QuickStopActive => 0x0007,
            DriveState::FaultReactionActive => 0x000F,
            DriveState::Fault => 0x0008,
            DriveState::Unknown => 0x006F,
        };
        bits | 0x0210 // voltage enabled (bit 4), remote (bit 9)
    }

    /// The controlword that moves a drive in this state toward operation
    /// enabled (the standard enable sequence, with fault reset).
    pub fn next_enable_command(&self) -> u16 {
        match self {
            DriveState::Fault => controlword::FAULT_RESET,
            DriveState::SwitchOnDisabled | DriveState::NotReadyToSwitchOn => controlword::SHUTDOWN,
            DriveState::ReadyToSwitchOn => controlword::SWITCH_ON,
            DriveState::SwitchedOn | DriveState::OperationEnabled => controlword::ENABLE_OPERATION,
            DriveState::QuickStopActive | DriveState::FaultReactionActive | DriveState::Unknown => {
                controlword::DISABLE_VOLTAGE
            }
        }
    }
}

pub fn rpdo1(node: u8, controlword: u16, target_velocity: i32) -> CanFrame {
    let mut d = [0u8; 6];
    d[..2].copy_from_slice(&controlword.to_le_bytes());
    d[2..].copy_from_slice(&target_velocity.to_le_bytes());
    CanFrame::new(RPDO1_BASE + node as u16, &d)
}

pub fn tpdo1(node: u8, statusword: u16, velocity: i32) -> CanFrame {
    let mut d = [0u8; 6];
    d[..2].copy_from_slice(&statusword.to_le_bytes());
    d[2..].copy_from_slice(&velocity.to_le_bytes());
    CanFrame::new(TPDO1_BASE + node as u16, &d)
}

/// TPDO2: position actual, and torque actual when the drive maps it.
pub fn tpdo2(node: u8, position: i32, torque: Option<i16>) -> CanFrame {
    let mut d = [0u8; 6];
    d[..4].copy_from_slice(&position.to_le_bytes());
    match torque {
        Some(t) => {
            d[4..].copy_from_slice(&t.to_le_bytes());
            CanFrame::new(TPDO2_BASE + node as u16, &d)
        }
        None => CanFrame::new(TPDO2_BASE + node as u16, &d[..4]),
    }
}

pub fn sync() -> CanFrame {
    CanFrame::new(SYNC_ID, &[])
}

/// A frame of Speleo's PDO mapping, decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pdo {
    Sync,
    Command {
        node: u8,
        controlword: u16,
        target_velocity: i32,
    },
    Status {
        node: u8,
        statusword: u16,
        velocity: i32,
    },
    Position {
        node: u8,
        position: i32,
        /// Torque actual, thousandths of the rated torque; `None` when the
        /// drive maps position alone.
        torque: Option<i16>,
    },
}

/// Why a frame is not a PDO of our mapping.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PdoError {
    /// Not a COB-ID of the mapping (other CANopen traffic: NMT, SDO, heartbeat).
    Unmapped,
    WrongLength {
        id: u32,
        len: u8,
    },
}

pub fn decode(f: &CanFrame) -> Result<Pdo, PdoError> {
    if f.extended || f.rtr {
        return Err(PdoError::Unmapped);
    }
    let id = f.id as u16;
    let p = f.payload();
    let wrong = || PdoError::WrongLength {
        id: f.id,
        len: f.len,
    };
    let node = (id & 0x7f) as u8;
    match id & !0x7f {
        _ if id == SYNC_ID => {
            if p.is_empty() {
                Ok(Pdo::Sync)
            } else {
                Err(wrong())
            }
        }
        RPDO1_BASE if node != 0 => match p {
            [a, b, c, d, e, g] => Ok(Pdo::Command {
                node,
                controlword: u16::from_le_bytes([*a, *b]),
                target_velocity: i32::from_le_bytes([*c, *d, *e, *g]),
            }),
            _ => Err(wrong()),
        },
        TPDO1_BASE if node != 0 => match p {
            [a, b, c, d, e, g] => Ok(Pdo::Status {
                node,
                statusword: u16::from_le_bytes([*a, *b]),
                velocity: i32::from_le_bytes([*c, *d, *e, *g]),
            }),
            _ => Err(wrong()),
        },
        TPDO2_BASE if node != 0 => match p {
            [a, b, c, d] => Ok(Pdo::Position {
                node,
                position: i32::from_le_bytes([*a, *b, *c, *d]),
                torque: None,
            }),
            [a, b, c, d, e, g] => Ok(Pdo::Position {
                node,
                position: i32::from_le_bytes([*a, *b, *c, *d]),
                torque: Some(i16::from_le_bytes([*e, *g])),
            }),
            _ => Err(wrong()),
        },
        _ => Err(PdoError::Unmapped),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epos_enable_sequence_statuswords_decode() {
        // maxon EPOS trace (../shared/data/can): 0x0740 -> 0x0721 -> 0x0723 -> 0x0737.
        assert_eq!(
            DriveState::from_statusword(0x0740),
            DriveState::SwitchOnDisabled
        );
        assert_eq!(
            DriveState::from_statusword(0x0721),
            DriveState::ReadyToSwitchOn
        );
        assert_eq!(DriveState::from_statusword(0x0723), DriveState::SwitchedOn);
        assert_eq!(
            DriveState::from_statusword(0x0737),
            DriveState::OperationEnabled
        );
        assert_eq!(DriveState::SwitchOnDisabled.next_enable_command(), 0x0006);
        assert_eq!(DriveState::ReadyToSwitchOn.next_enable_command(), 0x0007);
        assert_eq!(DriveState::SwitchedOn.next_enable_command(), 0x000F);
    }

    #[test]
    fn pdo_round_trips() {
        for f in [
            rpdo1(3, 0x0F, -1234),
            tpdo1(2, 0x0637, 99),
            tpdo2(4, i32::MIN, None),
            tpdo2(1, 77, Some(-1234)),
            sync(),
        ] {
            let p = decode(&f).expect("mapped");
            let back = match p {
                Pdo::Sync => sync(),
                Pdo::Command {
                    node,
                    controlword,
                    target_velocity,
                } => rpdo1(node, controlword, target_velocity),
                Pdo::Status {
                    node,
                    statusword,
                    velocity,
                } => tpdo1(node, statusword, velocity),
                Pdo::Position {
                    node,
                    position,
                    torque,
                } => tpdo2(node, position, torque),
            };
            assert_eq!(back, f);
        }
    }

    #[test]
    fn other_traffic_and_bad_lengths_are_reported() {
        assert_eq!(decode(&CanFrame::new(0x702, &[5])), Err(PdoError::Unmapped));
        assert!(matches!(
            decode(&CanFrame::new(0x182, &[1, 2, 3])),
            Err(PdoError::WrongLength { .. })
        ));
        assert!(matches!(
            decode(&CanFrame::new(0x080, &[1])),
            Err(PdoError::WrongLength { .. })
        ));
        // Position with half a torque.
        assert!(matches!(
            decode(&CanFrame::new(0x281, &[1, 2, 3, 4, 5])),
            Err(PdoError::WrongLength { .. })
        ));
    }

    #[test]
    fn torque_actual_counts_thousandths_of_the_rated_torque() {
        assert_eq!(torque_per_mille(15.0), 1000);
        assert_eq!(torque_per_mille(-7.5), -500);
        assert_eq!(torque_nm(1000), 15.0);
        assert_eq!(torque_per_mille(1e9), i16::MAX);
        assert_eq!(torque_per_mille(f64::NAN), 0);
    }
}
