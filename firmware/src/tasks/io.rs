//! Hardware I/O at the frame boundary: put last frame's CAN commands on the
//! bus, then collect every raw input that has arrived.
//!
//! Sending at the start of the next frame gives commands a fixed, jitter-free
//! latency of one minor frame whatever the tasks' execution times.

use speleo_hal::Hardware;
use speleo_scheduler::{Context, Task};

use crate::bus::Bus;

pub struct IoTask<'h> {
    hw: &'h mut dyn Hardware,
}

impl<'h> IoTask<'h> {
    pub fn new(hw: &'h mut dyn Hardware) -> Self {
        IoTask { hw }
    }
}

impl Task<Bus> for IoTask<'_> {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let now = cx.time_ns;
        self.hw.advance_to(now);
        while let Some(f) = bus.can_tx.pop() {
            if self.hw.can().send(now, &f).is_err() {
                bus.counters.hal_errors += 1;
            }
        }
        while let Some(m) = bus.imu_tx.pop() {
            if self.hw.imu().write(&m).is_err() {
                bus.counters.hal_errors += 1;
            }
        }
        bus.raw.clear();
        let raw = &mut bus.raw;
        let errors = [
            self.hw.lidar().poll(now, raw).is_err(),
            self.hw.imu().poll(now, raw).is_err(),
            self.hw.can().poll(now, raw).is_err(),
        ];
        bus.counters.hal_errors += errors.iter().filter(|e| **e).count() as u64;
        bus.counters.raw_dropped = bus.raw.dropped;
        bus.counters.can_tx_dropped = bus.can_tx.dropped();
    }
}
