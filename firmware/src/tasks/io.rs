//! Hardware I/O at the frame boundary: put last frame's CAN commands on the
//! bus, then collect every raw input that has arrived.
//!
//! Sending at the start of the next frame gives commands a fixed, jitter-free
//! latency of one minor frame whatever the tasks' execution times.
//!
//! A simulated world is normally advanced between frames by the mission
//! loop (it is the outside world, not on-board work); the `advance_to` here
//! only catches up after a slipped frame.

use std::cell::RefCell;

use speleo_hal::{HalError, Hardware};
use speleo_scheduler::{Context, Task};

use crate::bus::Bus;

pub struct IoTask<'r, 'h> {
    hw: &'r RefCell<&'h mut dyn Hardware>,
}

impl<'r, 'h> IoTask<'r, 'h> {
    pub fn new(hw: &'r RefCell<&'h mut dyn Hardware>) -> Self {
        IoTask { hw }
    }
}

impl Task<Bus> for IoTask<'_, '_> {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let now = cx.time_ns;
        let mut hw = self.hw.borrow_mut();
        hw.advance_to(now);
        while let Some(f) = bus.can_tx.pop() {
            if let Err(e) = hw.can().send(now, &f) {
                bus.counters.hal_errors += 1;
                if matches!(e, HalError::BusOff) {
                    bus.counters.can_errors += 1;
                }
            }
        }
        while let Some(m) = bus.imu_tx.pop() {
            if hw.imu().write(&m).is_err() {
                bus.counters.hal_errors += 1;
            }
        }
        bus.raw.clear();
        let raw = &mut bus.raw;
        let lidar = hw.lidar().poll(now, raw).is_err();
        let imu = hw.imu().poll(now, raw).is_err();
        let can = hw.can().poll(now, raw).is_err();
        if can {
            bus.counters.can_errors += 1;
        }
        let errors = [lidar, imu, can];
        bus.counters.hal_errors += errors.iter().filter(|e| **e).count() as u64;
        bus.counters.can_transport_dropped = hw.can().dropped_input();
        bus.counters.raw_dropped = bus.raw.dropped;
        bus.counters.can_tx_dropped = bus.can_tx.dropped();
    }

    /// Nothing was collected in a skipped frame: the drivers and the
    /// recorder must not take the last frame's inputs again. They wait in
    /// the devices' buffers for the next run.
    fn skipped(&mut self, bus: &mut Bus) {
        bus.raw.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use speleo_hal::{Device, InputSink};

    #[test]
    fn a_skipped_run_leaves_no_inputs_for_the_drivers_to_take_again() {
        let mut replay = speleo_hal::replay::ReplayHardware::new(10_000, Vec::new());
        let hw: RefCell<&mut dyn Hardware> = RefCell::new(&mut replay);
        let mut io = IoTask::new(&hw);
        let mut bus = Bus::new();
        bus.raw.input(Device::Imu, 5, &[0xfa, 0xff]);
        io.skipped(&mut bus);
        assert!(bus.raw.entries().is_empty());
    }
}
