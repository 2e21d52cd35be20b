//! Puts the drives' commands for the next frame on the CAN bus through the
//! CANopen supervisor: bring-up (SDO, NMT), the CiA 402 enable sequence,
//! target velocities, SYNC. Every wheel gets zero in safe mode, without a
//! fresh command, when a drive's heartbeat is lost or when a drive faults.

use speleo_hal::canopen::supervisor::{DrivesState, Supervisor, SupervisorParams};
use speleo_scheduler::{Context, Mode, Task};

use crate::bus::Bus;

pub struct DriveOutput {
    supervisor: Supervisor,
}

impl DriveOutput {
    pub fn new(p: SupervisorParams) -> Self {
        DriveOutput {
            supervisor: Supervisor::new(p),
        }
    }
}

impl Task<Bus> for DriveOutput {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let state = bus.drives.get().map_or(DrivesState::default(), |d| d.value);
        let command = bus
            .command
            .get()
            .map(|c| (c.stamp_ns, c.value.wheel_speeds));
        let tx = &mut bus.can_tx;
        let reasons = self.supervisor.plan(
            cx.time_ns,
            &state,
            command,
            cx.mode == Mode::Safe,
            &mut |f| {
                tx.push(f);
            },
        );
        bus.drive_stop.publish(cx.time_ns, reasons);
    }
}
