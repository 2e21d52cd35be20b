//! The health monitor: from the devices' counters and time stamps, the
//! odometry's wheel slips and the executive's timing, the findings of one
//! check, and whether they ask for the safe schedule or let it be left.

use crate::finding::*;
use crate::{Freshness, Source, SourceId};

/// The watched sources, in bit order of the stale mask.
pub const SOURCE_NAMES: [&str; 6] = ["imu", "drive1", "drive2", "drive3", "drive4", "lidar"];

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

/// One drive as the monitor sees it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DriveHealth {
    /// Its last heartbeat, ns (0: never).
    pub heartbeat_time_ns: u64,
    /// In fault or reacting to one.
    pub faulted: bool,
}

/// What one check reads: counters since start-up, time stamps, flags.
#[derive(Clone, Copy, Debug, Default)]
pub struct HealthInput {
    pub now_ns: u64,
    /// The executive's frame, ns: slipped frames are this long each.
    pub minor_frame_ns: u64,
    pub lidar_packets: u64,
    /// IMU frames refused (bad checksum, oversize) and bytes skipped
    /// hunting for a frame.
    pub imu_errors: u64,
    pub imu_skipped_bytes: u64,
    pub can_errors: u64,
    /// Each drive, once any feedback came.
    pub drives: Option<[DriveHealth; 4]>,
    /// The drive output reports a failure (lost heartbeat, fault, refused
    /// SDO, bad command).
    pub drive_failures: bool,
    /// Odometry steps that left each wheel out.
    pub wheel_slips: [u64; 4],
    pub overruns: u64,
    pub slipped_frames: u64,
    /// The executive enforces its budgets (real time).
    pub enforcing: bool,
}

/// One check's result.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HealthVerdict {
    /// Stale sources, by [`SOURCE_NAMES`] bit.
    pub stale_mask: u32,
    /// Drives in fault.
    pub drive_faults: u8,
    /// [`crate::finding`] bits.
    pub findings: u16,
    /// The findings ask the executive for the safe schedule.
    pub safe_mode_request: bool,
    /// Nothing found for long enough: the safe schedule may be left.
    pub recovery_ready: bool,
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

pub struct HealthMonitor {
    p: HealthParams,
    fresh: Freshness,
    imu: SourceId,
    drives: [SourceId; 4],
    lidar: SourceId,
    seen: Seen,
    noisy_imu_checks: u32,
    wheel_checks: [u32; 4],
    storm: [u64; STORM_WINDOW],
    storm_at: usize,
    last_finding_ns: Option<u64>,
}

impl HealthMonitor {
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
        HealthMonitor {
            p,
            fresh,
            imu,
            drives,
            lidar,
            seen: Seen::default(),
            noisy_imu_checks: 0,
            wheel_checks: [0; 4],
            storm: [0; STORM_WINDOW],
            storm_at: 0,
            last_finding_ns: None,
        }
    }

    /// An IMU sample stamped `stamp_ns` arrived.
    pub fn imu_seen(&mut self, stamp_ns: u64) {
        self.fresh.seen(self.imu, stamp_ns);
    }

    /// One check: the findings, and what they ask of the executive.
    pub fn check(&mut self, i: &HealthInput) -> HealthVerdict {
        let now = i.now_ns;
        let (devices, stale, drive_faults) = self.device_findings(i);
        let findings = devices | self.motion_and_timing_findings(i);
        let silence = IMU_SILENT | LIDAR_SILENT | DRIVE_SILENT;
        let acting = if self.p.safe_on_stale {
            findings
        } else {
            findings & !silence
        };
        if findings != 0 {
            self.last_finding_ns = Some(now);
        }
        HealthVerdict {
            stale_mask: stale,
            drive_faults,
            findings,
            safe_mode_request: acting != 0,
            recovery_ready: self.p.recover_after_ns > 0
                && acting == 0
                && self
                    .last_finding_ns
                    .is_none_or(|t| now.saturating_sub(t) >= self.p.recover_after_ns),
        }
    }

    /// Devices: silence, noise, faults, bus errors.
    fn device_findings(&mut self, i: &HealthInput) -> (u16, u32, u8) {
        let now = i.now_ns;
        let mut found = 0;
        if i.lidar_packets != self.seen.lidar_packets {
            self.seen.lidar_packets = i.lidar_packets;
            self.fresh.seen(self.lidar, now);
        }
        let noisy = i.imu_errors > self.seen.imu_errors
            || i.imu_skipped_bytes > self.seen.imu_skipped + IMU_SKIPPED_BYTES;
        (self.seen.imu_errors, self.seen.imu_skipped) = (i.imu_errors, i.imu_skipped_bytes);
        self.noisy_imu_checks = if noisy { self.noisy_imu_checks + 1 } else { 0 };
        if self.noisy_imu_checks >= 2 {
            found |= IMU_GARBAGE;
        }
        if i.can_errors > self.seen.can_errors {
            found |= CAN_ERROR;
        }
        self.seen.can_errors = i.can_errors;
        let mut faults = 0u8;
        if let Some(drives) = &i.drives {
            for (d, id) in drives.iter().zip(self.drives) {
                if d.heartbeat_time_ns != 0 {
                    self.fresh.seen(id, d.heartbeat_time_ns);
                }
                if d.faulted {
                    faults += 1;
                }
            }
        }
        if faults > 0 || i.drive_failures {
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
    fn motion_and_timing_findings(&mut self, i: &HealthInput) -> u16 {
        let mut found = 0;
        for ((now, before), checks) in i
            .wheel_slips
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
        self.seen.wheel_slips = i.wheel_slips;
        // On virtual time an overrun costs nothing (the world waits for
        // the frame); only an executive that enforces its budgets storms.
        self.storm[self.storm_at] = i.overruns.saturating_sub(self.seen.overruns);
        self.storm_at = (self.storm_at + 1) % STORM_WINDOW;
        self.seen.overruns = i.overruns;
        let in_window: u64 = self.storm.iter().sum();
        if i.enforcing && self.p.storm_overruns > 0 && in_window >= self.p.storm_overruns {
            found |= OVERRUN_STORM;
        }
        let slipped = i.slipped_frames.saturating_sub(self.seen.slipped_frames);
        self.seen.slipped_frames = i.slipped_frames;
        if slipped * i.minor_frame_ns >= self.p.clock_jump_ns {
            found |= CLOCK_JUMP;
        }
        found
    }
}
