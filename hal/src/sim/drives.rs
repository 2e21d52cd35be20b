//! Twins of the four CiA 402 wheel drives in profile velocity mode.
//!
//! Each drive runs the profile's state machine on the controlwords it
//! receives, answers every SYNC with TPDO1 (statusword, velocity) and TPDO2
//! (position) after a small per-node latency, and stops its wheel when its
//! commands go stale (the drive's own watchdog).

use super::rover::{Rover, WHEELS};
use crate::can::CanFrame;
use crate::cia402::{self, DriveState, Pdo};
use crate::outbox::Outbox;

#[derive(Clone, Debug, PartialEq)]
pub struct DriveParams {
    /// Delay between a SYNC and node 1's answer; node n answers n times later.
    pub response_latency_ns: u64,
    /// The drive stops its wheel when no command came for this long.
    pub command_timeout_ns: u64,
}

impl Default for DriveParams {
    fn default() -> Self {
        DriveParams {
            response_latency_ns: 150_000,
            command_timeout_ns: 200_000_000,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Drive {
    state: DriveState,
    last_controlword: u16,
    /// mrad/s at the wheel.
    target: i32,
    last_command_ns: Option<u64>,
    velocity: i32,
    position: i32,
}

pub struct SimDrives {
    p: DriveParams,
    drives: [Drive; WHEELS],
    outbox: Outbox<64, 16>,
    unknown_frames: u64,
}

impl SimDrives {
    pub fn new(p: DriveParams) -> Self {
        SimDrives {
            p,
            drives: [Drive {
                state: DriveState::SwitchOnDisabled,
                last_controlword: 0,
                target: 0,
                last_command_ns: None,
                velocity: 0,
                position: 0,
            }; WHEELS],
            outbox: Outbox::new(),
            unknown_frames: 0,
        }
    }

    pub(crate) fn outbox(&mut self) -> &mut Outbox<64, 16> {
        &mut self.outbox
    }

    pub fn dropped(&self) -> u64 {
        self.outbox.dropped()
    }

    /// Frames on the bus that no drive understood.
    pub fn unknown_frames(&self) -> u64 {
        self.unknown_frames
    }

    pub fn state(&self, wheel: usize) -> Option<DriveState> {
        self.drives.get(wheel).map(|d| d.state)
    }

    /// A frame arrives on the bus at `now_ns`.
    pub fn receive(&mut self, now_ns: u64, frame: &CanFrame) {
        match cia402::decode(frame) {
            Ok(Pdo::Sync) => {
                for (i, d) in self.drives.iter().enumerate() {
                    let node = i as u8 + 1;
                    let t = now_ns + self.p.response_latency_ns * node as u64;
                    self.outbox.push(
                        t,
                        &cia402::tpdo1(node, d.state.statusword(), d.velocity).to_socketcan(),
                    );
                    self.outbox
                        .push(t, &cia402::tpdo2(node, d.position).to_socketcan());
                }
            }
            Ok(Pdo::Command {
                node,
                controlword,
                target_velocity,
            }) if (1..=WHEELS as u8).contains(&node) => {
                let d = &mut self.drives[node as usize - 1];
                d.state = transition(d.state, d.last_controlword, controlword);
                d.last_controlword = controlword;
                d.target = target_velocity;
                d.last_command_ns = Some(now_ns);
            }
            _ => self.unknown_frames += 1,
        }
    }

    /// Wheel speeds (rad/s) the drives aim at, at time `now_ns`.
    pub fn wheel_targets(&self, now_ns: u64) -> [f64; WHEELS] {
        let mut out = [0.0; WHEELS];
        for (o, d) in out.iter_mut().zip(self.drives.iter()) {
            let fresh = d
                .last_command_ns
                .is_some_and(|t| now_ns.saturating_sub(t) <= self.p.command_timeout_ns);
            if d.state == DriveState::OperationEnabled && fresh {
                *o = d.target as f64 * 1e-3;
            }
        }
        out
    }

    /// Read the encoders of the rover's wheels.
    pub fn observe(&mut self, rover: &Rover) {
        let per_rad = cia402::COUNTS_PER_REV as f64 / (2.0 * core::f64::consts::PI);
        for (i, d) in self.drives.iter_mut().enumerate() {
            d.velocity = (rover.wheel_speed[i] * 1000.0).round() as i32;
            // Encoders wrap like the drive's 32-bit position register.
            d.position = ((rover.wheel_angle[i] * per_rad).round() as i64) as i32;
        }
    }
}

/// The CiA 402 state machine (device control, figure 6 of the profile),
/// driven by one controlword.
fn transition(s: DriveState, previous_cw: u16, cw: u16) -> DriveState {
    use DriveState::*;
    let fault_reset_edge = cw & 0x80 != 0 && previous_cw & 0x80 == 0;
    if s == Fault {
        return if fault_reset_edge {
            SwitchOnDisabled
        } else {
            Fault
        };
    }
    if cw & 0x80 != 0 {
        return s;
    }
    let disable_voltage = cw & 0x02 == 0;
    let quick_stop = cw & 0x06 == 0x02;
    let shutdown = cw & 0x07 == 0x06;
    let switch_on = cw & 0x0F == 0x07;
    let enable = cw & 0x0F == 0x0F;
    match s {
        NotReadyToSwitchOn => SwitchOnDisabled,
        SwitchOnDisabled if shutdown => ReadyToSwitchOn,
        ReadyToSwitchOn | SwitchedOn | OperationEnabled if disable_voltage => SwitchOnDisabled,
        ReadyToSwitchOn if switch_on => SwitchedOn,
        ReadyToSwitchOn if enable => OperationEnabled,
        SwitchedOn if enable => OperationEnabled,
        SwitchedOn | OperationEnabled if shutdown => ReadyToSwitchOn,
        OperationEnabled if switch_on => SwitchedOn,
        OperationEnabled if quick_stop => QuickStopActive,
        QuickStopActive if disable_voltage => SwitchOnDisabled,
        FaultReactionActive => Fault,
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_epos_enable_sequence_reaches_operation_enabled() {
        let mut s = SimDrives::new(DriveParams::default());
        for (i, cw) in [0x0006u16, 0x0007, 0x000F].into_iter().enumerate() {
            s.receive(i as u64, &cia402::rpdo1(2, cw, 0));
        }
        assert_eq!(s.state(1), Some(DriveState::OperationEnabled));
        assert_eq!(s.state(0), Some(DriveState::SwitchOnDisabled));
    }

    #[test]
    fn only_enabled_drives_with_fresh_commands_turn() {
        let mut s = SimDrives::new(DriveParams::default());
        for cw in [0x0006u16, 0x0007, 0x000F] {
            s.receive(0, &cia402::rpdo1(1, cw, 1500));
        }
        s.receive(0, &cia402::rpdo1(2, 0x0006, 1500));
        let t = s.wheel_targets(1_000_000);
        assert_eq!(t, [1.5, 0.0, 0.0, 0.0]);
        // Stale after the drive's timeout.
        assert_eq!(s.wheel_targets(300_000_000), [0.0; 4]);
    }

    #[test]
    fn sync_is_answered_by_every_drive_after_its_latency() {
        let mut s = SimDrives::new(DriveParams::default());
        s.receive(1_000, &cia402::sync());
        assert!(s.outbox().pop_due(1_000).is_none());
        let mut n = 0;
        while s.outbox().pop_due(10_000_000).is_some() {
            n += 1;
        }
        assert_eq!(n, 8);
    }
}
