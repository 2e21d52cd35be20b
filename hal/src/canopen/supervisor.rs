//! Supervising the four CiA 402 wheel drives.
//!
//! Input side: [`DrivesState::apply`] folds every decoded frame into what is
//! known of each node (NMT state and heartbeat time, statusword, velocity,
//! position, emergencies, SDO answers).
//!
//! Output side: [`Supervisor::plan`] decides, every frame, what to put on the
//! bus. A node is brought up step by step: once it is heard (boot-up or
//! heartbeat), an SDO write sets profile velocity mode (0x6060 = 3); then NMT
//! Start; then the CiA 402 enable sequence through RPDO1; then velocity
//! commands, followed by SYNC.
//!
//! Safety: every wheel is commanded to zero when the executive is in safe
//! mode, when the wheel command is missing or older than its freshness limit,
//! when any drive's heartbeat is lost, or when any drive reports a fault. A
//! skid-steer rover with one wheel out must not drive on the others. A
//! drive's fault is reset (controlword bit 7) once it has stood for
//! `fault_reset_ns`, and again every `fault_reset_ns` while its cause
//! remains: a rover out of radio reach has no operator to do it. With
//! `fault_reset_ns` = 0 faults are never reset. The reasons are reported.

use crate::can::CanFrame;
use crate::cia402::{self, DriveState, Pdo};

use super::sdo::Sdo;
use super::{classify, nmt, Event, NmtCommand, NmtState};

pub const WHEELS: usize = 4;
/// Modes of operation (0x6060) value for profile velocity.
pub const PROFILE_VELOCITY: u32 = 3;

/// What is known of one drive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeFeedback {
    pub state: DriveState,
    pub statusword: u16,
    /// mrad/s at the wheel.
    pub velocity: i32,
    /// Encoder increments.
    pub position: i32,
    /// Torque actual with the position, thousandths of the rated torque
    /// (`None`: the drive does not map it, or nothing came yet).
    pub torque: Option<i16>,
    /// Receive times, 0 = never.
    pub status_time_ns: u64,
    pub position_time_ns: u64,
    pub heartbeat_time_ns: u64,
    pub nmt: Option<NmtState>,
    pub boot_ups: u32,
    pub emergencies: u32,
    pub last_emergency: u16,
    /// Profile velocity mode confirmed by the drive (SDO download response).
    pub mode_set: bool,
    /// The last SDO abort code from this drive.
    pub sdo_abort: Option<u32>,
}

impl Default for NodeFeedback {
    fn default() -> Self {
        NodeFeedback {
            state: DriveState::NotReadyToSwitchOn,
            statusword: 0,
            velocity: 0,
            position: 0,
            torque: None,
            status_time_ns: 0,
            position_time_ns: 0,
            heartbeat_time_ns: 0,
            nmt: None,
            boot_ups: 0,
            emergencies: 0,
            last_emergency: 0,
            mode_set: false,
            sdo_abort: None,
        }
    }
}

/// The four drives (node ids 1..=4: front left, front right, rear left, rear right).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DrivesState {
    pub nodes: [NodeFeedback; WHEELS],
}

/// Counters of what the input side could not use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InputCounters {
    pub malformed: u64,
    /// Traffic for other nodes or other objects.
    pub other: u64,
}

fn wheel_of(node: u8) -> Option<usize> {
    (1..=WHEELS as u8)
        .contains(&node)
        .then(|| node as usize - 1)
}

impl DrivesState {
    /// Fold one received frame in. Returns true when it changed what is known.
    pub fn apply(&mut self, f: &CanFrame, t_ns: u64, c: &mut InputCounters) -> bool {
        let t = t_ns.max(1);
        match classify(f) {
            Event::Heartbeat { node, state } => match wheel_of(node) {
                Some(w) => {
                    let n = &mut self.nodes[w];
                    if state == NmtState::BootUp {
                        // A (re)booted drive starts over.
                        *n = NodeFeedback {
                            boot_ups: n.boot_ups.saturating_add(1),
                            emergencies: n.emergencies,
                            last_emergency: n.last_emergency,
                            ..NodeFeedback::default()
                        };
                        n.nmt = Some(NmtState::PreOperational);
                    } else {
                        n.nmt = Some(state);
                    }
                    n.heartbeat_time_ns = t;
                    true
                }
                None => {
                    c.other += 1;
                    false
                }
            },
            Event::Pdo(Pdo::Status {
                node,
                statusword,
                velocity,
            }) => match wheel_of(node) {
                Some(w) => {
                    let n = &mut self.nodes[w];
                    n.statusword = statusword;
                    n.state = DriveState::from_statusword(statusword);
                    n.velocity = velocity;
                    n.status_time_ns = t;
                    true
                }
                None => {
                    c.other += 1;
                    false
                }
            },
            Event::Pdo(Pdo::Position {
                node,
                position,
                torque,
            }) => match wheel_of(node) {
                Some(w) => {
                    self.nodes[w].position = position;
                    self.nodes[w].torque = torque;
                    self.nodes[w].position_time_ns = t;
                    true
                }
                None => {
                    c.other += 1;
                    false
                }
            },
            Event::Emcy { node, code, .. } => match wheel_of(node) {
                Some(w) => {
                    // Code 0 is "error reset / no error": the emergency is over.
                    if code != 0 {
                        self.nodes[w].emergencies = self.nodes[w].emergencies.saturating_add(1);
                    }
                    self.nodes[w].last_emergency = code;
                    true
                }
                None => {
                    c.other += 1;
                    false
                }
            },
            Event::SdoResponse { node, sdo } => match (wheel_of(node), sdo) {
                (
                    Some(w),
                    Sdo::DownloadResponse {
                        index: 0x6060,
                        sub: 0,
                    },
                ) => {
                    self.nodes[w].mode_set = true;
                    true
                }
                // Only the answer to our own request (modes of operation)
                // counts; a service tool's failed read of another object
                // is not the drive's failure.
                (
                    Some(w),
                    Sdo::Abort {
                        index: 0x6060,
                        code,
                        ..
                    },
                ) => {
                    self.nodes[w].sdo_abort = Some(code);
                    true
                }
                _ => {
                    c.other += 1;
                    false
                }
            },
            Event::Malformed { .. } => {
                c.malformed += 1;
                false
            }
            // Our own requests echoed, other PDOs, SYNC from another master.
            _ => {
                c.other += 1;
                false
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SupervisorParams {
    /// A drive whose last heartbeat is older than this is lost.
    pub heartbeat_timeout_ns: u64,
    /// A wheel command older than this is stale.
    pub command_timeout_ns: u64,
    /// SDO and NMT requests are repeated this often until answered.
    pub retry_ns: u64,
    /// A drive never heard from within this time after start is lost.
    pub boot_grace_ns: u64,
    /// Largest target velocity sent, mrad/s at the wheel.
    pub max_velocity: i32,
    /// A drive's fault is reset after standing this long, and again as
    /// often while it stays (0: never reset).
    pub fault_reset_ns: u64,
}

/// Why the wheels are held at zero (empty when they may turn).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StopReasons {
    pub safe_mode: bool,
    pub no_command: bool,
    pub stale_command: bool,
    /// Bit w: drive w's heartbeat is lost.
    pub heartbeat_lost: u8,
    /// Bit w: drive w reports a fault.
    pub fault: u8,
    /// Bit w: drive w is still being brought up.
    pub not_ready: u8,
    /// Bit w: drive w refused an SDO (abort).
    pub sdo_refused: u8,
    /// The wheel command holds a value that is not a number.
    pub bad_command: bool,
}

impl StopReasons {
    pub fn any(&self) -> bool {
        self.safe_mode
            || self.no_command
            || self.stale_command
            || self.heartbeat_lost != 0
            || self.fault != 0
            || self.not_ready != 0
            || self.sdo_refused != 0
            || self.bad_command
    }

    /// Reasons that mean something is wrong (not just starting up or idle):
    /// the ones the health monitor answers with the safe schedule.
    pub fn failures(&self) -> bool {
        self.heartbeat_lost != 0 || self.fault != 0 || self.sdo_refused != 0 || self.bad_command
    }
}

pub struct Supervisor {
    p: SupervisorParams,
    last_sdo_ns: [Option<u64>; WHEELS],
    last_nmt_ns: [Option<u64>; WHEELS],
    last_preop_ns: [Option<u64>; WHEELS],
    /// When the fault of a drive in Fault was first seen or last reset.
    last_fault_reset_ns: [Option<u64>; WHEELS],
    fault_resets: u64,
}

impl Supervisor {
    pub fn new(p: SupervisorParams) -> Self {
        Supervisor {
            p,
            last_sdo_ns: [None; WHEELS],
            last_nmt_ns: [None; WHEELS],
            last_preop_ns: [None; WHEELS],
            last_fault_reset_ns: [None; WHEELS],
            fault_resets: 0,
        }
    }

    /// Fault resets sent so far.
    pub fn fault_resets(&self) -> u64 {
        self.fault_resets
    }

    /// The controlword for a drive in Fault: a reset (a rising edge of bit
    /// 7) when one is due, else disable voltage.
    fn fault_controlword(&mut self, w: usize, now: u64) -> u16 {
        let last = self.last_fault_reset_ns[w].get_or_insert(now);
        if self.p.fault_reset_ns > 0 && now.saturating_sub(*last) >= self.p.fault_reset_ns {
            *last = now;
            self.fault_resets += 1;
            cia402::controlword::FAULT_RESET
        } else {
            cia402::controlword::DISABLE_VOLTAGE
        }
    }

    fn due(last: &mut Option<u64>, now: u64, retry: u64) -> bool {
        if last.is_some_and(|t| now.saturating_sub(t) < retry) {
            return false;
        }
        *last = Some(now);
        true
    }

    /// The frames for this frame, handed to `out`, and why the wheels are
    /// held at zero. `command` is the wheel speeds (rad/s) with their stamp.
    pub fn plan(
        &mut self,
        now: u64,
        st: &DrivesState,
        command: Option<(u64, [f64; WHEELS])>,
        safe_mode: bool,
        out: &mut dyn FnMut(CanFrame),
    ) -> StopReasons {
        let mut r = StopReasons {
            safe_mode,
            ..StopReasons::default()
        };
        match command {
            None => r.no_command = true,
            Some((_, speeds)) if speeds.iter().any(|v| !v.is_finite()) => r.bad_command = true,
            Some((stamp, _)) if now.saturating_sub(stamp) > self.p.command_timeout_ns => {
                r.stale_command = true
            }
            _ => {}
        }
        for (w, n) in st.nodes.iter().enumerate() {
            let bit = 1u8 << w;
            let lost = if n.heartbeat_time_ns == 0 {
                now > self.p.boot_grace_ns
            } else {
                now.saturating_sub(n.heartbeat_time_ns) > self.p.heartbeat_timeout_ns
            };
            if lost {
                r.heartbeat_lost |= bit;
            }
            if matches!(n.state, DriveState::Fault | DriveState::FaultReactionActive) {
                r.fault |= bit;
            }
            if n.sdo_abort.is_some() {
                r.sdo_refused |= bit;
            }
            if !n.mode_set || n.nmt != Some(NmtState::Operational) {
                r.not_ready |= bit;
            }
        }
        let hold = r.any();
        for (w, n) in st.nodes.iter().enumerate() {
            let node = w as u8 + 1;
            if n.nmt.is_none() || n.sdo_abort.is_some() {
                continue; // not heard yet, or refused: nothing to say to it
            }
            if n.nmt == Some(NmtState::Stopped) {
                // SDO is not served in Stopped: back to pre-operational first.
                if Self::due(&mut self.last_preop_ns[w], now, self.p.retry_ns) {
                    out(nmt(NmtCommand::EnterPreOperational, node));
                }
                continue;
            }
            if !n.mode_set {
                if Self::due(&mut self.last_sdo_ns[w], now, self.p.retry_ns) {
                    out(Sdo::DownloadRequest {
                        index: 0x6060,
                        sub: 0,
                        value: PROFILE_VELOCITY,
                        len: 1,
                    }
                    .request(node));
                }
                continue;
            }
            if n.nmt != Some(NmtState::Operational) {
                if Self::due(&mut self.last_nmt_ns[w], now, self.p.retry_ns) {
                    out(nmt(NmtCommand::Start, node));
                }
                continue;
            }
            let controlword = match n.state {
                DriveState::Fault | DriveState::FaultReactionActive => {
                    self.fault_controlword(w, now)
                }
                s => {
                    self.last_fault_reset_ns[w] = None;
                    s.next_enable_command()
                }
            };
            let velocity = match command {
                Some((_, speeds)) if !hold && n.state == DriveState::OperationEnabled => {
                    let m = self.p.max_velocity as f64;
                    (speeds[w] * 1000.0).round().clamp(-m, m) as i32
                }
                _ => 0,
            };
            out(cia402::rpdo1(node, controlword, velocity));
        }
        out(cia402::sync());
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canopen::heartbeat;

    fn params() -> SupervisorParams {
        SupervisorParams {
            heartbeat_timeout_ns: 300_000_000,
            command_timeout_ns: 100_000_000,
            retry_ns: 200_000_000,
            boot_grace_ns: 1_000_000_000,
            max_velocity: 5_000,
            fault_reset_ns: 0,
        }
    }

    /// Four drives booted, in profile velocity mode, operational, enabled.
    fn running(t: u64) -> DrivesState {
        let mut s = DrivesState::default();
        let mut c = InputCounters::default();
        for node in 1..=4u8 {
            s.apply(&heartbeat(node, NmtState::Operational), t, &mut c);
            s.apply(
                &Sdo::DownloadResponse {
                    index: 0x6060,
                    sub: 0,
                }
                .response(node),
                t,
                &mut c,
            );
            s.apply(&cia402::tpdo1(node, 0x0637, 0), t, &mut c);
        }
        s
    }

    fn velocities(frames: &[CanFrame]) -> Vec<i32> {
        frames
            .iter()
            .filter_map(|f| match cia402::decode(f) {
                Ok(Pdo::Command {
                    target_velocity, ..
                }) => Some(target_velocity),
                _ => None,
            })
            .collect()
    }

    fn plan(
        s: &DrivesState,
        now: u64,
        command: Option<(u64, [f64; 4])>,
    ) -> (Vec<CanFrame>, StopReasons) {
        let mut sup = Supervisor::new(params());
        let mut frames = Vec::new();
        let r = sup.plan(now, s, command, false, &mut |f| frames.push(f));
        (frames, r)
    }

    #[test]
    fn a_healthy_rover_drives() {
        let s = running(1_000);
        let (frames, r) = plan(&s, 2_000, Some((1_500, [1.0, 2.0, 1.0, 2.0])));
        assert!(!r.any(), "{r:?}");
        assert_eq!(velocities(&frames), vec![1000, 2000, 1000, 2000]);
        assert_eq!(frames.last().map(|f| f.id), Some(0x080));
    }

    #[test]
    fn stale_commands_stop_the_wheels() {
        let s = running(1_000);
        let (frames, r) = plan(&s, 200_002_000, Some((1_500, [1.0; 4])));
        assert!(r.stale_command);
        assert_eq!(velocities(&frames), vec![0; 4]);
    }

    #[test]
    fn a_lost_heartbeat_stops_every_wheel() {
        let mut s = running(1_000);
        let mut c = InputCounters::default();
        // Three drives keep beating, drive 2 falls silent.
        for node in [1u8, 3, 4] {
            s.apply(&heartbeat(node, NmtState::Operational), 400_000_000, &mut c);
        }
        let (frames, r) = plan(&s, 400_000_000, Some((399_000_000, [1.0; 4])));
        assert_eq!(r.heartbeat_lost, 0b0010);
        assert!(r.failures());
        assert_eq!(velocities(&frames), vec![0; 4]);
    }

    /// Node 3's controlword in `frames`.
    fn controlword_of_3(frames: &[CanFrame]) -> Option<u16> {
        frames.iter().find_map(|f| match cia402::decode(f) {
            Ok(Pdo::Command {
                node: 3,
                controlword,
                ..
            }) => Some(controlword),
            _ => None,
        })
    }

    #[test]
    fn a_fault_statusword_stops_every_wheel_and_is_not_reset_when_resets_are_off() {
        let mut s = running(1_000);
        let mut c = InputCounters::default();
        s.apply(&cia402::tpdo1(3, 0x0608, 0), 2_000, &mut c);
        let mut sup = Supervisor::new(params());
        for t in [3_000, 5_000_000_000] {
            let mut frames = Vec::new();
            let r = sup.plan(t, &s, Some((t, [1.0; 4])), false, &mut |f| frames.push(f));
            assert_eq!(r.fault, 0b0100);
            assert_eq!(velocities(&frames), vec![0; 4]);
            assert_eq!(
                controlword_of_3(&frames),
                Some(cia402::controlword::DISABLE_VOLTAGE)
            );
        }
        assert_eq!(sup.fault_resets(), 0);
    }

    #[test]
    fn a_fault_is_reset_after_its_hold_off_and_again_while_it_stays() {
        let mut s = running(1_000);
        let mut c = InputCounters::default();
        s.apply(&cia402::tpdo1(3, 0x0608, 0), 2_000, &mut c);
        let mut sup = Supervisor::new(SupervisorParams {
            fault_reset_ns: 1_000_000_000,
            ..params()
        });
        let mut words = Vec::new();
        // 10 ms frames for 2.5 s, the drive staying in Fault.
        for k in 0..250u64 {
            let t = 10_000 + k * 10_000_000;
            let mut frames = Vec::new();
            let r = sup.plan(t, &s, Some((t, [1.0; 4])), false, &mut |f| frames.push(f));
            assert_eq!(velocities(&frames), vec![0; 4], "no wheel turns at {t}");
            assert_eq!(r.fault, 0b0100);
            words.push(controlword_of_3(&frames).expect("node 3 is commanded"));
        }
        let resets: Vec<usize> = (0..words.len())
            .filter(|&i| words[i] == cia402::controlword::FAULT_RESET)
            .collect();
        // A rising edge of bit 7 each time: reset frames are single.
        assert_eq!(resets, vec![100, 200]);
        assert_eq!(sup.fault_resets(), 2);
        // Once the drive has left Fault, it is enabled step by step again.
        s.apply(&cia402::tpdo1(3, 0x0640, 0), 2_600_000_000, &mut c);
        let mut frames = Vec::new();
        sup.plan(2_600_000_000, &s, None, false, &mut |f| frames.push(f));
        assert_eq!(
            controlword_of_3(&frames),
            Some(cia402::controlword::SHUTDOWN)
        );
    }

    #[test]
    fn speeds_are_clamped_and_nan_holds_everything() {
        let s = running(1_000);
        let (frames, r) = plan(&s, 2_000, Some((1_500, [9.0, -9.0, 1.0, 1.0])));
        assert!(!r.any());
        assert_eq!(velocities(&frames), vec![5000, -5000, 1000, 1000]);
        let (frames, r) = plan(&s, 2_000, Some((1_500, [1.0, f64::NAN, 1.0, 1.0])));
        assert!(r.bad_command && r.failures());
        assert_eq!(velocities(&frames), vec![0; 4]);
    }

    #[test]
    fn a_stopped_drive_is_brought_back_and_foreign_aborts_do_not_latch() {
        let mut s = DrivesState::default();
        let mut c = InputCounters::default();
        s.apply(&heartbeat(1, NmtState::Stopped), 10, &mut c);
        let mut sup = Supervisor::new(params());
        let mut frames = Vec::new();
        sup.plan(20, &s, None, false, &mut |f| frames.push(f));
        assert_eq!(
            (frames[0].id, frames[0].payload()),
            (0x000, &[0x80, 0x01][..])
        );
        // Someone else's read of a missing object is refused: not our failure.
        s.apply(
            &Sdo::Abort {
                index: 0x2000,
                sub: 0,
                code: 0x0602_0000,
            }
            .response(1),
            30,
            &mut c,
        );
        assert_eq!(s.nodes[0].sdo_abort, None);
        s.apply(
            &Sdo::Abort {
                index: 0x6060,
                sub: 0,
                code: 0x0609_0030,
            }
            .response(1),
            40,
            &mut c,
        );
        assert_eq!(s.nodes[0].sdo_abort, Some(0x0609_0030));
    }

    #[test]
    fn nodes_are_brought_up_step_by_step() {
        let mut s = DrivesState::default();
        let mut c = InputCounters::default();
        let mut sup = Supervisor::new(params());
        let mut frames = Vec::new();
        // Silent drives: nothing but SYNC, wheels held, not ready.
        let r = sup.plan(0, &s, None, false, &mut |f| frames.push(f));
        assert_eq!(frames.len(), 1);
        assert_eq!(r.not_ready, 0b1111);
        // Drive 1 boots: profile velocity mode by SDO first.
        s.apply(&heartbeat(1, NmtState::BootUp), 10, &mut c);
        frames.clear();
        sup.plan(20, &s, None, false, &mut |f| frames.push(f));
        assert_eq!(frames[0].id, 0x601);
        assert_eq!(
            frames[0].payload(),
            &[0x2F, 0x60, 0x60, 0x00, 0x03, 0, 0, 0]
        );
        // Confirmed: NMT start.
        s.apply(
            &Sdo::DownloadResponse {
                index: 0x6060,
                sub: 0,
            }
            .response(1),
            30,
            &mut c,
        );
        frames.clear();
        sup.plan(40, &s, None, false, &mut |f| frames.push(f));
        assert_eq!(
            (frames[0].id, frames[0].payload()),
            (0x000, &[0x01, 0x01][..])
        );
        // Operational: the enable sequence.
        s.apply(&heartbeat(1, NmtState::Operational), 50, &mut c);
        s.apply(&cia402::tpdo1(1, 0x0640, 0), 50, &mut c);
        frames.clear();
        sup.plan(60, &s, None, false, &mut |f| frames.push(f));
        assert_eq!(
            cia402::decode(&frames[0]),
            Ok(Pdo::Command {
                node: 1,
                controlword: 0x0006,
                target_velocity: 0
            })
        );
    }
}
