//! Watches the devices and the executive, and names what is wrong: an IMU,
//! LiDAR or drive gone quiet, an IMU line talking noise, a drive fault, CAN
//! errors, a wheel the odometry disagrees with, a storm of overruns, a
//! clock that jumped. Any finding asks the executive for the safe schedule;
//! once nothing has been found for `recover_after_ns`, it may leave it.

use speleo_hal::cia402::DriveState;
use speleo_health::{Freshness, Source, SourceId};
use speleo_scheduler::{Context, Mode, Task};

use crate::bus::Bus;
use speleo_messages::HealthReport;

pub const SOURCE_NAMES: [&str; 6] = ["imu", "drive1", "drive2", "drive3", "drive4", "lidar"];

/// The health task's findings, one bit each.
pub mod finding {
    pub const IMU_SILENT: u16 = 1 << 0;
    pub const IMU_GARBAGE: u16 = 1 << 1;
    pub const LIDAR_SILENT: u16 = 1 << 2;
    pub const DRIVE_SILENT: u16 = 1 << 3;
    pub const DRIVE_FAULT: u16 = 1 << 4;
    pub const CAN_ERROR: u16 = 1 << 5;
    pub const WHEEL: u16 = 1 << 6;
    pub const OVERRUN_STORM: u16 = 1 << 7;
    pub const CLOCK_JUMP: u16 = 1 << 8;

    pub const NAMES: [(u16, &str); 9] = [
        (IMU_SILENT, "imu_silent"),
        (IMU_GARBAGE, "imu_garbage"),
        (LIDAR_SILENT, "lidar_silent"),
        (DRIVE_SILENT, "drive_silent"),
        (DRIVE_FAULT, "drive_fault"),
        (CAN_ERROR, "can_error"),
        (WHEEL, "wheel"),
        (OVERRUN_STORM, "overrun_storm"),
        (CLOCK_JUMP, "clock_jump"),
    ];

    /// The names of the findings in `mask`.
    pub fn names(mask: u16) -> impl Iterator<Item = &'static str> {
        NAMES
            .iter()
            .filter(move |(bit, _)| mask & bit != 0)
            .map(|(_, n)| *n)
    }
}

/// Limits of the checks (see `[health]` in the configuration).
#[derive(Clone, Copy, Debug)]
pub struct HealthParams {
    pub imu_limit_ns: u64,
    pub drive_limit_ns: u64,
    pub lidar_limit_ns: u64,
    pub grace_ns: u64,
    /// Silence asks for the safe schedule (else it is only reported).
    pub safe_on_stale: bool,
    /// Consecutive checks in which a wheel was left out of most odometry
    /// steps before it is a finding.
    pub wheel_checks: u32,
    /// Overruns within the last second that make a storm (0: no check).
    pub storm_overruns: u64,
    /// A slip of the frame clock this long is a jump.
    pub clock_jump_ns: u64,
    /// Quiet time after which the safe schedule may be left (0: never).
    pub recover_after_ns: u64,
}

/// Checks in the storm window (one second at 10 Hz).
const STORM_WINDOW: usize = 10;
/// Odometry steps of a 100 ms check in which a wheel must be left out.
const WHEEL_STEPS: u64 = 5;
/// IMU bytes skipped while hunting for a frame that make a noisy check.
const IMU_SKIPPED_BYTES: u64 = 16;

/// Counter values at the previous check.
#[derive(Clone, Copy, Debug, Default)]
struct Seen {
    lidar_packets: u64,
    imu_errors: u64,
    imu_skipped: u64,
    can_errors: u64,
    wheel_slips: [u64; 4],
    overruns: u64,
    slipped_frames: u64,
}

pub struct HealthTask {
    p: HealthParams,
    fresh: Freshness,
    imu: SourceId,
    drives: [SourceId; 4],
    lidar: SourceId,
    imu_cursor: u64,
    seen: Seen,
    noisy_imu_checks: u32,
    wheel_checks: [u32; 4],
    storm: [u64; STORM_WINDOW],
    storm_at: usize,
    last_finding_ns: Option<u64>,
}

impl HealthTask {
    pub fn new(p: HealthParams) -> Self {
        let mut fresh = Freshness::new(p.grace_ns);
        let mut add = |name, limit_ns| {
            fresh
                .watch(Source { name, limit_ns })
                .unwrap_or_else(|| unreachable!("six sources fit the table"))
        };
        let imu = add(SOURCE_NAMES[0], p.imu_limit_ns);
        let drives = [1, 2, 3, 4].map(|i| add(SOURCE_NAMES[i], p.drive_limit_ns));
        // A rover may run without its LiDAR (replays of drive logs, tests),
        // so the LiDAR is watched from its first packet on.
        let lidar = add(SOURCE_NAMES[5], p.lidar_limit_ns);
        HealthTask {
            p,
            fresh,
            imu,
            drives,
            lidar,
            imu_cursor: 0,
            seen: Seen::default(),
            noisy_imu_checks: 0,
            wheel_checks: [0; 4],
            storm: [0; STORM_WINDOW],
            storm_at: 0,
            last_finding_ns: None,
        }
    }

    /// Devices: silence, noise, faults, bus errors.
    fn device_findings(&mut self, bus: &Bus, now: u64) -> (u16, u32, u8) {
        use finding::*;
        let mut found = 0;
        let c = &bus.counters;
        if bus.lidar.packets != self.seen.lidar_packets {
            self.seen.lidar_packets = bus.lidar.packets;
            self.fresh.seen(self.lidar, now);
        }
        let imu_errors = c.imu.bad_checksums + c.imu.oversize;
        let noisy = imu_errors > self.seen.imu_errors
            || c.imu.skipped_bytes > self.seen.imu_skipped + IMU_SKIPPED_BYTES;
        (self.seen.imu_errors, self.seen.imu_skipped) = (imu_errors, c.imu.skipped_bytes);
        self.noisy_imu_checks = if noisy { self.noisy_imu_checks + 1 } else { 0 };
        if self.noisy_imu_checks >= 2 {
            found |= IMU_GARBAGE;
        }
        if c.can_errors > self.seen.can_errors {
            found |= CAN_ERROR;
        }
        self.seen.can_errors = c.can_errors;
        let mut faults = 0u8;
        if let Some(d) = bus.drives.get() {
            for (w, id) in self.drives.iter().enumerate() {
                let n = &d.value.nodes[w];
                if n.heartbeat_time_ns != 0 {
                    self.fresh.seen(*id, n.heartbeat_time_ns);
                }
                if matches!(n.state, DriveState::Fault | DriveState::FaultReactionActive) {
                    faults += 1;
                }
            }
        }
        if faults > 0 || bus.drive_stop.get().is_some_and(|r| r.value.failures()) {
            found |= DRIVE_FAULT;
        }
        let stale = self.fresh.check(now);
        let heard_lidar = self.seen.lidar_packets > 0;
        if self.fresh.is_stale(self.imu, now) {
            found |= IMU_SILENT;
        }
        if self.drives.iter().any(|d| self.fresh.is_stale(*d, now)) {
            found |= DRIVE_SILENT;
        }
        if heard_lidar && self.fresh.is_stale(self.lidar, now) {
            found |= LIDAR_SILENT;
        }
        (found, stale, faults)
    }

    /// The odometry and the executive: a wheel left out, overruns, slips.
    fn motion_and_timing_findings(&mut self, bus: &Bus, cx: &Context) -> u16 {
        use finding::*;
        let mut found = 0;
        let slips = bus.odom_counters.wheel_slips;
        for ((now, before), checks) in slips
            .iter()
            .zip(self.seen.wheel_slips)
            .zip(self.wheel_checks.iter_mut())
        {
            let left_out = now.saturating_sub(before) >= WHEEL_STEPS;
            *checks = if left_out { *checks + 1 } else { 0 };
            if *checks >= self.p.wheel_checks.max(1) {
                found |= WHEEL;
            }
        }
        self.seen.wheel_slips = slips;
        // On virtual time an overrun costs nothing (the world waits for
        // the frame); only an executive that enforces its budgets storms.
        let t = &bus.timing;
        self.storm[self.storm_at] = t.overruns.saturating_sub(self.seen.overruns);
        self.storm_at = (self.storm_at + 1) % STORM_WINDOW;
        self.seen.overruns = t.overruns;
        let in_window: u64 = self.storm.iter().sum();
        if t.enforcing && self.p.storm_overruns > 0 && in_window >= self.p.storm_overruns {
            found |= OVERRUN_STORM;
        }
        let slipped = t.slipped_frames.saturating_sub(self.seen.slipped_frames);
        self.seen.slipped_frames = t.slipped_frames;
        if slipped * cx.minor_frame_ns >= self.p.clock_jump_ns {
            found |= CLOCK_JUMP;
        }
        found
    }
}

impl Task<Bus> for HealthTask {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let now = cx.time_ns;
        let fresh = &mut self.fresh;
        let imu = self.imu;
        bus.imu
            .read_since(&mut self.imu_cursor, |s| fresh.seen(imu, s.stamp_ns));
        let (devices, stale, drive_faults) = self.device_findings(bus, now);
        let findings = devices | self.motion_and_timing_findings(bus, cx);
        use finding::*;
        let silence = IMU_SILENT | LIDAR_SILENT | DRIVE_SILENT;
        let acting = if self.p.safe_on_stale {
            findings
        } else {
            findings & !silence
        };
        if findings != 0 {
            self.last_finding_ns = Some(now);
        }
        bus.safe_mode_request = acting != 0;
        bus.recovery_ready = self.p.recover_after_ns > 0
            && acting == 0
            && self
                .last_finding_ns
                .is_none_or(|t| now.saturating_sub(t) >= self.p.recover_after_ns);
        bus.health.publish(
            now,
            HealthReport {
                stale_mask: stale,
                drive_faults,
                findings,
                safe_mode: cx.mode == Mode::Safe || bus.safe_mode_request,
            },
        );
    }
}

#[cfg(test)]
mod tests {
    use super::finding::*;
    use super::*;
    use crate::tasks::test_context;
    use speleo_hal::canopen::supervisor::DrivesState;
    use speleo_messages::ImuSample;

    fn params() -> HealthParams {
        HealthParams {
            imu_limit_ns: 50_000_000,
            drive_limit_ns: 300_000_000,
            lidar_limit_ns: 300_000_000,
            grace_ns: 500_000_000,
            safe_on_stale: true,
            wheel_checks: 3,
            storm_overruns: 20,
            clock_jump_ns: 100_000_000,
            recover_after_ns: 2_000_000_000,
        }
    }

    /// A frame of a healthy rover: an IMU sample, the drives' heartbeats,
    /// LiDAR packets, and the odometry using every wheel.
    fn healthy_frame(bus: &mut Bus, frame: u64) {
        let now = frame * 10_000_000;
        bus.imu.publish(now, ImuSample::default());
        let mut d = DrivesState::default();
        for n in &mut d.nodes {
            n.heartbeat_time_ns = now;
            n.state = DriveState::OperationEnabled;
        }
        bus.drives.publish(now, d);
        bus.lidar.packets += 18;
    }

    /// Run `frames` frames from `first`, health every 10th, with `fault`
    /// applied to each frame after the healthy data; the last report.
    fn run(
        h: &mut HealthTask,
        bus: &mut Bus,
        first: u64,
        frames: u64,
        fault: impl Fn(&mut Bus),
    ) -> HealthReport {
        for f in first..first + frames {
            healthy_frame(bus, f);
            fault(bus);
            if f % 10 == 5 {
                h.run(bus, &test_context(f));
            }
        }
        bus.health.get().map(|s| s.value).unwrap_or_default()
    }

    #[test]
    fn a_healthy_rover_finds_nothing_and_may_leave_the_safe_schedule() {
        let (mut h, mut bus) = (HealthTask::new(params()), Bus::new());
        let r = run(&mut h, &mut bus, 0, 300, |_| {});
        assert_eq!(r.findings, 0);
        assert!(!bus.safe_mode_request && bus.recovery_ready);
    }

    #[test]
    fn a_wheel_left_out_for_300_ms_is_a_finding_and_200_ms_is_not() {
        let (mut h, mut bus) = (HealthTask::new(params()), Bus::new());
        run(&mut h, &mut bus, 0, 100, |_| {});
        let spin = |b: &mut Bus| b.odom_counters.wheel_slips[2] += 1;
        assert_eq!(run(&mut h, &mut bus, 100, 20, spin).findings, 0);
        run(&mut h, &mut bus, 120, 30, |_| {});
        let r = run(&mut h, &mut bus, 150, 30, spin);
        assert_eq!(r.findings, WHEEL);
        assert!(bus.safe_mode_request && !bus.recovery_ready);
        // Quiet again: the safe schedule may be left 2 s after the last
        // finding, not before.
        run(&mut h, &mut bus, 180, 190, |_| {});
        assert!(!bus.recovery_ready);
        run(&mut h, &mut bus, 370, 20, |_| {});
        assert!(bus.recovery_ready);
    }

    #[test]
    fn the_lidar_is_watched_from_its_first_packet() {
        let (mut h, mut bus) = (HealthTask::new(params()), Bus::new());
        let no_lidar = |b: &mut Bus| b.lidar.packets = 0;
        assert_eq!(run(&mut h, &mut bus, 0, 200, no_lidar).findings, 0);
        run(&mut h, &mut bus, 200, 50, |_| {});
        let frozen = bus.lidar.packets;
        let r = run(&mut h, &mut bus, 250, 50, |b: &mut Bus| {
            b.lidar.packets = frozen
        });
        assert_eq!(r.findings, LIDAR_SILENT);
        assert_eq!(names(r.findings).collect::<Vec<_>>(), vec!["lidar_silent"]);
    }

    #[test]
    fn noise_on_the_imu_line_twice_running_is_garbage() {
        let (mut h, mut bus) = (HealthTask::new(params()), Bus::new());
        run(&mut h, &mut bus, 0, 100, |_| {});
        // One bad frame is a glitch.
        bus.counters.imu.bad_checksums += 1;
        assert_eq!(run(&mut h, &mut bus, 100, 10, |_| {}).findings, 0);
        let noise = |b: &mut Bus| b.counters.imu.skipped_bytes += 40;
        assert_eq!(run(&mut h, &mut bus, 110, 20, noise).findings, IMU_GARBAGE);
    }

    #[test]
    fn a_clock_jump_and_can_errors_are_findings_and_storms_only_when_enforcing() {
        let (mut h, mut bus) = (HealthTask::new(params()), Bus::new());
        run(&mut h, &mut bus, 0, 100, |_| {});
        bus.timing.slipped_frames += 10;
        assert_eq!(run(&mut h, &mut bus, 100, 10, |_| {}).findings, CLOCK_JUMP);
        assert_eq!(run(&mut h, &mut bus, 110, 10, |_| {}).findings, 0);
        bus.counters.can_errors += 1;
        assert_eq!(run(&mut h, &mut bus, 120, 10, |_| {}).findings, CAN_ERROR);
        // Every frame over budget on virtual time: nothing.
        let storm = |b: &mut Bus| b.timing.overruns += 1;
        assert_eq!(run(&mut h, &mut bus, 130, 100, storm).findings, 0);
        bus.timing.enforcing = true;
        assert_eq!(
            run(&mut h, &mut bus, 230, 30, storm).findings,
            OVERRUN_STORM
        );
    }
}
