//! The health monitor over frames of a simulated healthy rover, with
//! faults laid over them.

use speleo_health::finding::*;
use speleo_health::{DriveHealth, HealthInput, HealthMonitor, HealthParams, HealthVerdict};

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

/// What the rover's counters and stamps say, frame after frame.
#[derive(Default)]
struct Rover {
    input: HealthInput,
    imu_stamp_ns: Option<u64>,
}

impl Rover {
    /// A frame of a healthy rover: an IMU sample, the drives' heartbeats,
    /// LiDAR packets, and the odometry using every wheel.
    fn healthy_frame(&mut self, frame: u64) {
        let now = frame * 10_000_000;
        self.imu_stamp_ns = Some(now);
        self.input.drives = Some(
            [DriveHealth {
                heartbeat_time_ns: now,
                faulted: false,
            }; 4],
        );
        self.input.lidar_packets += 18;
    }
}

/// Run `frames` frames from `first`, a check every 10th, with `fault`
/// applied to each frame after the healthy data; the last verdict.
fn run(
    h: &mut HealthMonitor,
    r: &mut Rover,
    first: u64,
    frames: u64,
    fault: impl Fn(&mut Rover),
) -> HealthVerdict {
    let mut last = HealthVerdict::default();
    for f in first..first + frames {
        r.healthy_frame(f);
        fault(r);
        if let Some(t) = r.imu_stamp_ns.take() {
            h.imu_seen(t);
        }
        if f % 10 == 5 {
            r.input.now_ns = f * 10_000_000;
            r.input.minor_frame_ns = 10_000_000;
            last = h.check(&r.input);
        }
    }
    last
}

#[test]
fn a_healthy_rover_finds_nothing_and_may_leave_the_safe_schedule() {
    let (mut h, mut r) = (HealthMonitor::new(params()), Rover::default());
    let v = run(&mut h, &mut r, 0, 300, |_| {});
    assert_eq!(v.findings, 0);
    assert!(!v.safe_mode_request && v.recovery_ready);
}

#[test]
fn a_wheel_left_out_for_300_ms_is_a_finding_and_200_ms_is_not() {
    let (mut h, mut r) = (HealthMonitor::new(params()), Rover::default());
    run(&mut h, &mut r, 0, 100, |_| {});
    let spin = |r: &mut Rover| r.input.wheel_slips[2] += 1;
    assert_eq!(run(&mut h, &mut r, 100, 20, spin).findings, 0);
    run(&mut h, &mut r, 120, 30, |_| {});
    let v = run(&mut h, &mut r, 150, 30, spin);
    assert_eq!(v.findings, WHEEL);
    assert!(v.safe_mode_request && !v.recovery_ready);
    // Quiet again: the safe schedule may be left 2 s after the last
    // finding, not before.
    assert!(!run(&mut h, &mut r, 180, 190, |_| {}).recovery_ready);
    assert!(run(&mut h, &mut r, 370, 20, |_| {}).recovery_ready);
}

#[test]
fn the_lidar_is_watched_from_its_first_packet() {
    let (mut h, mut r) = (HealthMonitor::new(params()), Rover::default());
    let no_lidar = |r: &mut Rover| r.input.lidar_packets = 0;
    assert_eq!(run(&mut h, &mut r, 0, 200, no_lidar).findings, 0);
    run(&mut h, &mut r, 200, 50, |_| {});
    let frozen = r.input.lidar_packets;
    let v = run(&mut h, &mut r, 250, 50, |r: &mut Rover| {
        r.input.lidar_packets = frozen
    });
    assert_eq!(v.findings, LIDAR_SILENT);
    assert_eq!(names(v.findings).collect::<Vec<_>>(), vec!["lidar_silent"]);
}

#[test]
fn noise_on_the_imu_line_twice_running_is_garbage() {
    let (mut h, mut r) = (HealthMonitor::new(params()), Rover::default());
    run(&mut h, &mut r, 0, 100, |_| {});
    // One bad frame is a glitch.
    r.input.imu_errors += 1;
    assert_eq!(run(&mut h, &mut r, 100, 10, |_| {}).findings, 0);
    let noise = |r: &mut Rover| r.input.imu_skipped_bytes += 40;
    assert_eq!(run(&mut h, &mut r, 110, 20, noise).findings, IMU_GARBAGE);
}

#[test]
fn a_clock_jump_and_can_errors_are_findings_and_storms_only_when_enforcing() {
    let (mut h, mut r) = (HealthMonitor::new(params()), Rover::default());
    run(&mut h, &mut r, 0, 100, |_| {});
    r.input.slipped_frames += 10;
    assert_eq!(run(&mut h, &mut r, 100, 10, |_| {}).findings, CLOCK_JUMP);
    assert_eq!(run(&mut h, &mut r, 110, 10, |_| {}).findings, 0);
    r.input.can_errors += 1;
    assert_eq!(run(&mut h, &mut r, 120, 10, |_| {}).findings, CAN_ERROR);
    // Every frame over budget on virtual time: nothing.
    let storm = |r: &mut Rover| r.input.overruns += 1;
    assert_eq!(run(&mut h, &mut r, 130, 100, storm).findings, 0);
    r.input.enforcing = true;
    assert_eq!(run(&mut h, &mut r, 230, 30, storm).findings, OVERRUN_STORM);
}

#[test]
fn a_drive_in_fault_is_a_finding_and_counted() {
    let (mut h, mut r) = (HealthMonitor::new(params()), Rover::default());
    run(&mut h, &mut r, 0, 100, |_| {});
    let fault = |r: &mut Rover| {
        if let Some(d) = &mut r.input.drives {
            d[1].faulted = true;
        }
    };
    let v = run(&mut h, &mut r, 100, 10, fault);
    assert_eq!((v.findings, v.drive_faults), (DRIVE_FAULT, 1));
    let v = run(&mut h, &mut r, 110, 10, |r: &mut Rover| {
        r.input.drive_failures = true
    });
    assert_eq!((v.findings, v.drive_faults), (DRIVE_FAULT, 0));
}
