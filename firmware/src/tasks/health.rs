//! Watches the devices: an IMU or a drive that goes silent, or a drive that
//! reports a fault, asks the executive for the safe schedule.

use speleo_hal::cia402::DriveState;
use speleo_health::{Freshness, Source, SourceId};
use speleo_scheduler::{Context, Mode, Task};

use crate::bus::{Bus, HealthReport};

pub const SOURCE_NAMES: [&str; 5] = ["imu", "drive1", "drive2", "drive3", "drive4"];

pub struct HealthTask {
    fresh: Freshness,
    imu: SourceId,
    drives: [SourceId; 4],
    imu_cursor: u64,
    safe_on_stale: bool,
}

impl HealthTask {
    pub fn new(imu_limit_ns: u64, drive_limit_ns: u64, grace_ns: u64, safe_on_stale: bool) -> Self {
        let mut fresh = Freshness::new(grace_ns);
        let mut add = |name, limit_ns| {
            fresh
                .watch(Source { name, limit_ns })
                .unwrap_or_else(|| unreachable!("five sources fit the table"))
        };
        let imu = add(SOURCE_NAMES[0], imu_limit_ns);
        let drives = [1, 2, 3, 4].map(|i| add(SOURCE_NAMES[i], drive_limit_ns));
        HealthTask {
            fresh,
            imu,
            drives,
            imu_cursor: 0,
            safe_on_stale,
        }
    }
}

impl Task<Bus> for HealthTask {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let fresh = &mut self.fresh;
        let imu = self.imu;
        bus.imu
            .read_since(&mut self.imu_cursor, |s| fresh.seen(imu, s.stamp_ns));
        let mut faults = 0u8;
        if let Some(d) = bus.drives.get() {
            for (w, id) in self.drives.iter().enumerate() {
                let n = &d.value.nodes[w];
                if n.heartbeat_time_ns != 0 {
                    fresh.seen(*id, n.heartbeat_time_ns);
                }
                if matches!(n.state, DriveState::Fault | DriveState::FaultReactionActive) {
                    faults += 1;
                }
            }
        }
        let stale = fresh.check(cx.time_ns);
        let drive_failure = bus.drive_stop.get().is_some_and(|r| r.value.failures());
        if (stale != 0 && self.safe_on_stale) || faults > 0 || drive_failure {
            bus.safe_mode_request = true;
        }
        bus.health.publish(
            cx.time_ns,
            HealthReport {
                stale_mask: stale,
                drive_faults: faults,
                safe_mode: cx.mode == Mode::Safe || bus.safe_mode_request,
            },
        );
    }
}
