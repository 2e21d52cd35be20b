//! Twins of the four CANopen CiA 402 wheel drives.
//!
//! Each drive boots into pre-operational (boot-up message), sends a
//! heartbeat every `heartbeat_ns`, obeys NMT commands, serves expedited SDO
//! for its device type, heartbeat time, controlword, statusword, modes of
//! operation and the actual values, and, when operational, runs the
//! profile's state machine on the RPDO controlwords and answers every SYNC
//! with TPDO1 (statusword, velocity) and TPDO2 (position, torque). It stops its wheel
//! when its commands go stale (the drive's own watchdog) or when it is not in
//! profile velocity mode.

use speleo_hal::can::CanFrame;
use speleo_hal::canopen::sdo::{Sdo, ABORT_NO_OBJECT, ABORT_READ_ONLY, ABORT_VALUE_RANGE};
use speleo_hal::canopen::{self, classify, Event, NmtCommand, NmtState};
use speleo_hal::cia402::{self, DriveState, Pdo};
use speleo_hal::outbox::Outbox;
use speleo_physics::body::{BodyState, WHEELS};

#[derive(Clone, Debug, PartialEq)]
pub struct DriveParams {
    /// Delay between a SYNC and node 1's answer; node n answers n times later.
    pub response_latency_ns: u64,
    /// The drive stops its wheel when no command came for this long.
    pub command_timeout_ns: u64,
    /// Heartbeat producer time (object 0x1017).
    pub heartbeat_ns: u64,
    /// Time from power-on to the boot-up message.
    pub boot_ns: u64,
}

impl Default for DriveParams {
    fn default() -> Self {
        DriveParams {
            response_latency_ns: 150_000,
            command_timeout_ns: 200_000_000,
            heartbeat_ns: 100_000_000,
            boot_ns: 20_000_000,
        }
    }
}

/// Device type (0x1000): CiA 402 drive, as the real drives in the captures report.
pub const DEVICE_TYPE: u32 = 0x0002_0192;

#[derive(Clone, Copy, Debug)]
struct Drive {
    state: DriveState,
    last_controlword: u16,
    /// mrad/s at the wheel.
    target: i32,
    last_command_ns: Option<u64>,
    velocity: i32,
    position: i32,
    /// Torque actual (0x6077), thousandths of the rated torque.
    torque: i16,
    nmt: Option<NmtState>,
    mode: i8,
    /// Is this drive's power (and CAN transceiver) on? Tests switch it off.
    powered: bool,
    next_heartbeat_ns: u64,
    /// When a booting drive sends its boot-up message.
    boot_at_ns: u64,
    /// The cause of an injected fault lasts until then: a fault reset
    /// before it leaves the drive in Fault.
    fault_until_ns: u64,
    /// The motor is blocked (fault injection): the wheel is held still.
    stuck: bool,
    /// Encoder turns per turn of ground travel (1: rolling; fault injection
    /// of a wheel spinning on loose ground).
    spin: f64,
    /// Encoder angle gained by spinning, rad, and the wheel angle last seen.
    spun_rad: f64,
    last_angle_rad: f64,
}

pub struct DrivesTwin {
    p: DriveParams,
    drives: [Drive; WHEELS],
    outbox: Outbox<64, 16>,
    unknown_frames: u64,
    now_ns: u64,
}

impl DrivesTwin {
    pub fn new(p: DriveParams) -> Self {
        DrivesTwin {
            p: p.clone(),
            drives: [Drive {
                state: DriveState::SwitchOnDisabled,
                last_controlword: 0,
                target: 0,
                last_command_ns: None,
                velocity: 0,
                position: 0,
                torque: 0,
                nmt: None,
                mode: 0,
                powered: true,
                next_heartbeat_ns: 0,
                boot_at_ns: p.boot_ns,
                fault_until_ns: 0,
                stuck: false,
                spin: 1.0,
                spun_rad: 0.0,
                last_angle_rad: 0.0,
            }; WHEELS],
            outbox: Outbox::new(),
            unknown_frames: 0,
            now_ns: 0,
        }
    }

    /// Cut or restore a drive's power (fault injection).
    pub fn set_powered(&mut self, wheel: usize, on: bool) {
        let boot_at = self.now_ns + self.p.boot_ns;
        if let Some(d) = self.drives.get_mut(wheel) {
            if on && !d.powered {
                d.boot_at_ns = boot_at;
            }
            d.powered = on;
            if !on {
                d.nmt = None;
                d.state = DriveState::SwitchOnDisabled;
                d.mode = 0;
            }
        }
    }

    /// Put a drive in the fault state (fault injection). Its cause never
    /// clears: a fault reset leaves it in Fault.
    pub fn inject_fault(&mut self, wheel: usize) {
        self.inject_fault_until(wheel, u64::MAX);
    }

    /// Put a drive in the fault state with a cause that clears at
    /// `until_ns` (an over-temperature, say): a fault reset after that
    /// brings it back to Switch On Disabled.
    pub fn inject_fault_until(&mut self, wheel: usize, until_ns: u64) {
        if let Some(d) = self.drives.get_mut(wheel) {
            d.state = DriveState::Fault;
            d.fault_until_ns = until_ns;
        }
    }

    /// Block or free a wheel's motor (fault injection): a blocked wheel is
    /// held still whatever it is commanded.
    pub fn set_stuck(&mut self, wheel: usize, stuck: bool) {
        if let Some(d) = self.drives.get_mut(wheel) {
            d.stuck = stuck;
        }
    }

    /// Make a wheel's encoder turn `factor` times as far as the wheel rolls
    /// over the ground (fault injection of a wheel spinning in loose
    /// ground; 1 = rolling).
    pub fn set_spin(&mut self, wheel: usize, factor: f64) {
        if let Some(d) = self.drives.get_mut(wheel) {
            d.spin = if factor.is_finite() { factor } else { 1.0 };
        }
    }

    fn send(&mut self, t: u64, f: &CanFrame) {
        self.outbox.push(t, &f.to_socketcan());
    }

    /// Boot-up messages and heartbeats due by `now_ns`.
    pub fn tick(&mut self, now_ns: u64) {
        self.now_ns = now_ns;
        for i in 0..WHEELS {
            let node = i as u8 + 1;
            let d = self.drives[i];
            if !d.powered {
                continue;
            }
            if d.nmt.is_none() {
                if now_ns >= d.boot_at_ns {
                    self.drives[i].nmt = Some(NmtState::PreOperational);
                    self.drives[i].next_heartbeat_ns = now_ns + self.p.heartbeat_ns;
                    self.send(now_ns, &canopen::heartbeat(node, NmtState::BootUp));
                }
                continue;
            }
            if now_ns >= d.next_heartbeat_ns {
                self.drives[i].next_heartbeat_ns = d.next_heartbeat_ns + self.p.heartbeat_ns;
                if let Some(s) = d.nmt {
                    self.send(now_ns, &canopen::heartbeat(node, s));
                }
            }
        }
    }

    fn sdo(&mut self, w: usize, req: Sdo) -> Sdo {
        let d = &mut self.drives[w];
        let read = |index: u16, sub: u8, value: u32, len: u8| Sdo::UploadResponse {
            index,
            sub,
            value,
            len,
        };
        match req {
            Sdo::UploadRequest { index, sub } => match (index, sub) {
                (0x1000, 0) => read(index, sub, DEVICE_TYPE, 4),
                (0x1017, 0) => read(index, sub, (self.p.heartbeat_ns / 1_000_000) as u32, 2),
                (0x6040, 0) => read(index, sub, d.last_controlword as u32, 2),
                (0x6041, 0) => read(index, sub, d.state.statusword() as u32, 2),
                (0x6060, 0) | (0x6061, 0) => read(index, sub, d.mode as u8 as u32, 1),
                (0x6064, 0) => read(index, sub, d.position as u32, 4),
                (0x606C, 0) => read(index, sub, d.velocity as u32, 4),
                (0x6076, 0) => read(index, sub, cia402::RATED_TORQUE_MNM, 4),
                (0x6077, 0) => read(index, sub, d.torque as u16 as u32, 2),
                (0x60FF, 0) => read(index, sub, d.target as u32, 4),
                _ => Sdo::Abort {
                    index,
                    sub,
                    code: ABORT_NO_OBJECT,
                },
            },
            Sdo::DownloadRequest {
                index, sub, value, ..
            } => match (index, sub) {
                (0x6060, 0) => {
                    // Profile velocity (3) is the only mode this twin has.
                    if value == 3 {
                        d.mode = 3;
                        Sdo::DownloadResponse { index, sub }
                    } else {
                        Sdo::Abort {
                            index,
                            sub,
                            code: ABORT_VALUE_RANGE,
                        }
                    }
                }
                (0x6040, 0) => {
                    let cw = value as u16;
                    d.state = transition(d.state, d.last_controlword, cw);
                    d.last_controlword = cw;
                    Sdo::DownloadResponse { index, sub }
                }
                (0x60FF, 0) => {
                    d.target = value as i32;
                    Sdo::DownloadResponse { index, sub }
                }
                (0x1000, 0)
                | (0x6041, 0)
                | (0x6061, 0)
                | (0x6064, 0)
                | (0x606C, 0)
                | (0x6076, 0)
                | (0x6077, 0) => Sdo::Abort {
                    index,
                    sub,
                    code: ABORT_READ_ONLY,
                },
                _ => Sdo::Abort {
                    index,
                    sub,
                    code: ABORT_NO_OBJECT,
                },
            },
            Sdo::Abort { index, sub, .. }
            | Sdo::UploadResponse { index, sub, .. }
            | Sdo::DownloadResponse { index, sub } => Sdo::Abort {
                index,
                sub,
                code: speleo_hal::canopen::sdo::ABORT_UNSUPPORTED,
            },
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
        let operational = |d: &Drive| d.powered && d.nmt == Some(NmtState::Operational);
        match classify(frame) {
            Event::Sync => {
                for i in 0..WHEELS {
                    let d = self.drives[i];
                    if !operational(&d) {
                        continue;
                    }
                    let node = i as u8 + 1;
                    let t = now_ns + self.p.response_latency_ns * node as u64;
                    self.send(t, &cia402::tpdo1(node, d.state.statusword(), d.velocity));
                    self.send(t, &cia402::tpdo2(node, d.position, Some(d.torque)));
                }
            }
            Event::Nmt { command, node } => {
                let boot_at = now_ns + self.p.boot_ns;
                for i in 0..WHEELS {
                    let d = &mut self.drives[i];
                    if !(node == 0 || node as usize == i + 1) || !d.powered || d.nmt.is_none() {
                        continue;
                    }
                    match command {
                        NmtCommand::Start => d.nmt = Some(NmtState::Operational),
                        NmtCommand::Stop => d.nmt = Some(NmtState::Stopped),
                        NmtCommand::EnterPreOperational => d.nmt = Some(NmtState::PreOperational),
                        NmtCommand::ResetNode | NmtCommand::ResetCommunication => {
                            // Reboots: a new boot-up message after the boot
                            // time. Only a node reset loses the application
                            // parameters (the mode of operation).
                            d.nmt = None;
                            d.boot_at_ns = boot_at;
                            if command == NmtCommand::ResetNode {
                                d.state = DriveState::SwitchOnDisabled;
                                d.mode = 0;
                            }
                        }
                    }
                }
            }
            Event::SdoRequest { node, sdo } if (1..=WHEELS as u8).contains(&node) => {
                let w = node as usize - 1;
                let d = self.drives[w];
                if d.powered && d.nmt.is_some_and(|s| s != NmtState::Stopped) {
                    let answer = self.sdo(w, sdo);
                    self.send(now_ns + self.p.response_latency_ns, &answer.response(node));
                }
            }
            Event::Pdo(Pdo::Command {
                node,
                controlword,
                target_velocity,
            }) if (1..=WHEELS as u8).contains(&node) => {
                let d = &mut self.drives[node as usize - 1];
                if !operational(d) {
                    return;
                }
                let cause_active = now_ns < d.fault_until_ns;
                let next = transition(d.state, d.last_controlword, controlword);
                // A fault reset does not clear a fault whose cause remains.
                if !(d.state == DriveState::Fault && cause_active) {
                    d.state = next;
                }
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
            let running = d.powered && d.nmt == Some(NmtState::Operational) && d.mode == 3;
            if running && d.state == DriveState::OperationEnabled && fresh && !d.stuck {
                *o = d.target as f64 * 1e-3;
            }
        }
        out
    }

    /// Read the encoders of the rover's wheels.
    pub fn observe(&mut self, rover: &BodyState) {
        let per_rad = cia402::COUNTS_PER_REV as f64 / (2.0 * core::f64::consts::PI);
        for (i, d) in self.drives.iter_mut().enumerate() {
            let angle = rover.wheel_angle[i];
            d.spun_rad += (d.spin - 1.0) * (angle - d.last_angle_rad);
            d.last_angle_rad = angle;
            d.velocity = (rover.wheel_speed[i] * d.spin * 1000.0).round() as i32;
            d.torque = cia402::torque_per_mille(rover.wheel_torque[i]);
            // Encoders wrap like the drive's 32-bit position register.
            d.position = (((angle + d.spun_rad) * per_rad).round() as i64) as i32;
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
        // Transitions 7 and 10: quick stop before operation disables.
        ReadyToSwitchOn | SwitchedOn if quick_stop => SwitchOnDisabled,
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

    /// Boot the drives, set profile velocity mode and start them.
    fn started() -> DrivesTwin {
        let mut s = DrivesTwin::new(DriveParams::default());
        s.tick(20_000_000);
        for node in 1..=4u8 {
            s.receive(
                20_000_000,
                &Sdo::DownloadRequest {
                    index: 0x6060,
                    sub: 0,
                    value: 3,
                    len: 1,
                }
                .request(node),
            );
        }
        s.receive(20_000_000, &canopen::nmt(NmtCommand::Start, 0));
        while s.outbox().pop_due(u64::MAX).is_some() {}
        s
    }

    #[test]
    fn the_epos_enable_sequence_reaches_operation_enabled() {
        let mut s = started();
        for (i, cw) in [0x0006u16, 0x0007, 0x000F].into_iter().enumerate() {
            s.receive(i as u64, &cia402::rpdo1(2, cw, 0));
        }
        assert_eq!(s.state(1), Some(DriveState::OperationEnabled));
        assert_eq!(s.state(0), Some(DriveState::SwitchOnDisabled));
    }

    #[test]
    fn only_enabled_drives_with_fresh_commands_turn() {
        let mut s = started();
        for cw in [0x0006u16, 0x0007, 0x000F] {
            s.receive(20_000_000, &cia402::rpdo1(1, cw, 1500));
        }
        s.receive(20_000_000, &cia402::rpdo1(2, 0x0006, 1500));
        let t = s.wheel_targets(21_000_000);
        assert_eq!(t, [1.5, 0.0, 0.0, 0.0]);
        // Stale after the drive's timeout.
        assert_eq!(s.wheel_targets(300_000_000), [0.0; 4]);
    }

    /// Enable drive `node` and command it `mrad_s` at `t`.
    fn enable(s: &mut DrivesTwin, node: u8, t: u64, mrad_s: i32) {
        for cw in [0x0006u16, 0x0007, 0x000F] {
            s.receive(t, &cia402::rpdo1(node, cw, mrad_s));
        }
    }

    #[test]
    fn a_blocked_wheel_is_held_and_a_spinning_one_over_reads() {
        let mut s = started();
        enable(&mut s, 1, 20_000_000, 1500);
        enable(&mut s, 2, 20_000_000, 1500);
        s.set_stuck(0, true);
        assert_eq!(s.wheel_targets(21_000_000), [0.0, 1.5, 0.0, 0.0]);
        s.set_stuck(0, false);
        assert_eq!(s.wheel_targets(21_000_000)[0], 1.5);
        // Both wheels turn 1 rad; wheel 2's encoder reads 2.5 rad.
        s.set_spin(1, 2.5);
        let mut b = BodyState {
            wheel_speed: [1.0; WHEELS],
            wheel_angle: [1.0; WHEELS],
            ..BodyState::default()
        };
        s.observe(&b);
        let per_rad = cia402::COUNTS_PER_REV as f64 / (2.0 * core::f64::consts::PI);
        assert_eq!(s.drives[0].position, per_rad.round() as i32);
        assert_eq!(s.drives[1].position, (2.5 * per_rad).round() as i32);
        assert_eq!(s.drives[1].velocity, 2500);
        // Rolling again, the encoder keeps what it over-read.
        s.set_spin(1, 1.0);
        b.wheel_angle = [2.0; WHEELS];
        s.observe(&b);
        assert_eq!(s.drives[1].position, (3.5 * per_rad).round() as i32);
    }

    #[test]
    fn a_fault_is_reset_only_once_its_cause_has_cleared() {
        let mut s = started();
        enable(&mut s, 3, 20_000_000, 0);
        s.inject_fault_until(2, 1_000_000_000);
        let reset = |s: &mut DrivesTwin, t: u64| {
            s.receive(t, &cia402::rpdo1(3, 0x0000, 0));
            s.receive(t, &cia402::rpdo1(3, 0x0080, 0));
        };
        reset(&mut s, 500_000_000);
        assert_eq!(s.state(2), Some(DriveState::Fault));
        reset(&mut s, 1_000_000_000);
        assert_eq!(s.state(2), Some(DriveState::SwitchOnDisabled));
        enable(&mut s, 3, 1_010_000_000, 0);
        assert_eq!(s.state(2), Some(DriveState::OperationEnabled));
    }

    #[test]
    fn sync_is_answered_by_every_operational_drive_after_its_latency() {
        let mut s = started();
        s.receive(30_000_000, &cia402::sync());
        assert!(s.outbox().pop_due(30_000_000).is_none());
        let mut n = 0;
        while s.outbox().pop_due(40_000_000).is_some() {
            n += 1;
        }
        assert_eq!(n, 8);
        // A drive without power says nothing.
        s.set_powered(2, false);
        s.receive(50_000_000, &cia402::sync());
        let mut n = 0;
        while s.outbox().pop_due(60_000_000).is_some() {
            n += 1;
        }
        assert_eq!(n, 6);
    }

    #[test]
    fn the_torque_a_wheel_takes_is_reported_with_its_position() {
        let mut s = started();
        let b = BodyState {
            wheel_torque: [3.0, -1.5, 0.0, 15.0],
            ..BodyState::default()
        };
        s.observe(&b);
        s.receive(30_000_000, &cia402::sync());
        let mut torques = [None; WHEELS];
        while let Some((_, bytes)) = s.outbox().pop_due(u64::MAX) {
            let f = CanFrame::from_socketcan(&bytes).expect("frame");
            if let Ok(Pdo::Position { node, torque, .. }) = cia402::decode(&f) {
                torques[node as usize - 1] = torque;
            }
        }
        assert_eq!(torques, [Some(200), Some(-100), Some(0), Some(1000)]);
        // And over SDO, with the rated torque it counts in.
        for (index, value, len) in [(0x6077, (-100i16) as u16 as u32, 2), (0x6076, 15_000, 4)] {
            s.receive(40_000_000, &Sdo::UploadRequest { index, sub: 0 }.request(2));
            let (_, bytes) = s.outbox().pop_due(u64::MAX).expect("answer");
            let f = CanFrame::from_socketcan(&bytes).expect("frame");
            assert_eq!(
                Sdo::parse_response(f.payload()),
                Some(Sdo::UploadResponse {
                    index,
                    sub: 0,
                    value,
                    len
                })
            );
        }
    }

    #[test]
    fn boot_up_heartbeat_and_sdo() {
        let mut s = DrivesTwin::new(DriveParams::default());
        s.tick(0);
        assert!(s.outbox().pop_due(u64::MAX).is_none(), "still booting");
        s.tick(20_000_000);
        let (_, b) = s.outbox().pop_due(u64::MAX).expect("boot-up");
        let f = CanFrame::from_socketcan(&b).expect("frame");
        assert_eq!((f.id, f.payload()), (0x701, &[0u8][..]));
        while s.outbox().pop_due(u64::MAX).is_some() {}
        s.receive(
            30_000_000,
            &Sdo::UploadRequest {
                index: 0x1000,
                sub: 0,
            }
            .request(2),
        );
        let (_, b) = s.outbox().pop_due(u64::MAX).expect("answer");
        let f = CanFrame::from_socketcan(&b).expect("frame");
        assert_eq!(
            Sdo::parse_response(f.payload()),
            Some(Sdo::UploadResponse {
                index: 0x1000,
                sub: 0,
                value: DEVICE_TYPE,
                len: 4
            })
        );
        s.tick(120_000_000);
        let mut beats = 0;
        while let Some((_, b)) = s.outbox().pop_due(u64::MAX) {
            let f = CanFrame::from_socketcan(&b).expect("frame");
            assert_eq!(f.payload(), &[0x7F]);
            beats += 1;
        }
        assert_eq!(beats, 4);
    }
}
