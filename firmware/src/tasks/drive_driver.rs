//! Decodes the drives' CAN frames (CiA 402 PDOs) into wheel feedback.

use speleo_hal::cia402::{self, DriveState, Pdo, PdoError};
use speleo_hal::{CanFrame, Device};
use speleo_scheduler::{Context, Task};

use crate::bus::{Bus, DriveFeedback};

#[derive(Default)]
pub struct DriveDriver {
    feedback: DriveFeedback,
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
            let t = entry.receive_time_ns;
            let wheel = |node: u8| (1..=4).contains(&node).then(|| node as usize - 1);
            match cia402::decode(&frame) {
                Ok(Pdo::Status {
                    node,
                    statusword,
                    velocity,
                }) => match wheel(node) {
                    Some(w) => {
                        let fb = &mut self.feedback.wheels[w];
                        fb.statusword = statusword;
                        fb.state = DriveState::from_statusword(statusword);
                        fb.velocity = velocity;
                        self.feedback.status_time_ns[w] = t;
                        newest = Some(t);
                    }
                    None => counters.can_unmapped += 1,
                },
                Ok(Pdo::Position { node, position }) => match wheel(node) {
                    Some(w) => {
                        self.feedback.wheels[w].position = position;
                        self.feedback.position_time_ns[w] = t;
                        newest = Some(t);
                    }
                    None => counters.can_unmapped += 1,
                },
                Ok(_) | Err(PdoError::Unmapped) => counters.can_unmapped += 1,
                Err(PdoError::WrongLength { .. }) => counters.can_bad_length += 1,
            }
        }
        if let Some(t) = newest {
            bus.drives.publish(t, self.feedback);
        }
    }
}
