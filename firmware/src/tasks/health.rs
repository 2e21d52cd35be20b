//! The health task: the health monitor (`speleo_health`) over the bus.
//! Each run feeds it the IMU samples since the last, the devices'
//! counters and stamps, the odometry's wheel slips and the executive's
//! timing, and publishes its report and its requests to the executive.

use speleo_hal::cia402::DriveState;
use speleo_health::{DriveHealth, HealthInput, HealthMonitor, HealthParams};
use speleo_scheduler::{Context, Mode, Task};

use crate::bus::Bus;
use speleo_messages::HealthReport;

pub struct HealthTask {
    monitor: HealthMonitor,
    imu_cursor: u64,
}

impl HealthTask {
    pub fn new(p: HealthParams) -> Self {
        HealthTask {
            monitor: HealthMonitor::new(p),
            imu_cursor: 0,
        }
    }
}

impl Task<Bus> for HealthTask {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let now = cx.time_ns;
        let monitor = &mut self.monitor;
        bus.imu
            .read_since(&mut self.imu_cursor, |s| monitor.imu_seen(s.stamp_ns));
        let c = &bus.counters;
        let drives = bus.drives.get().map(|d| {
            d.value.nodes.map(|n| DriveHealth {
                heartbeat_time_ns: n.heartbeat_time_ns,
                faulted: matches!(n.state, DriveState::Fault | DriveState::FaultReactionActive),
            })
        });
        let t = &bus.timing;
        let v = self.monitor.check(&HealthInput {
            now_ns: now,
            minor_frame_ns: cx.minor_frame_ns,
            lidar_packets: bus.lidar.packets,
            imu_errors: c.imu.bad_checksums + c.imu.oversize,
            imu_skipped_bytes: c.imu.skipped_bytes,
            can_errors: c.can_errors,
            drives,
            drive_failures: bus.drive_stop.get().is_some_and(|r| r.value.failures()),
            wheel_slips: bus.odom_counters.wheel_slips,
            overruns: t.overruns,
            slipped_frames: t.slipped_frames,
            enforcing: t.enforcing,
        });
        bus.safe_mode_request = v.safe_mode_request;
        bus.recovery_ready = v.recovery_ready;
        bus.health.publish(
            now,
            HealthReport {
                stale_mask: v.stale_mask,
                drive_faults: v.drive_faults,
                findings: v.findings,
                safe_mode: cx.mode == Mode::Safe || bus.safe_mode_request,
            },
        );
    }
}
