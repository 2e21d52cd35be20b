//! Decodes the drives' CAN frames (CANopen: heartbeats, PDOs, EMCY, SDO
//! answers) into what is known of each drive.

use speleo_hal::canopen::supervisor::{DrivesState, InputCounters};
use speleo_hal::{CanFrame, Device};
use speleo_scheduler::{Context, Task};

use crate::bus::Bus;

#[derive(Default)]
pub struct DriveDriver {
    state: DrivesState,
    counters: InputCounters,
}

impl Task<Bus> for DriveDriver {
    fn run(&mut self, bus: &mut Bus, _cx: &Context) {
        let mut newest = None;
        let counters = &mut bus.counters;
        for (entry, bytes) in bus.raw.of(Device::Can) {
            counters.can_frames += 1;
            let Ok(frame) = CanFrame::from_socketcan(bytes) else {
                counters.can_malformed += 1;
                continue;
            };
            if self
                .state
                .apply(&frame, entry.receive_time_ns, &mut self.counters)
            {
                newest = Some(entry.receive_time_ns);
            }
        }
        counters.can_bad_length = self.counters.malformed;
        counters.can_unmapped = self.counters.other;
        if let Some(t) = newest {
            bus.drives.publish(t, self.state);
        }
    }
}
