//! Turns the wheel command into CiA 402 PDOs for the next frame: the enable
//! sequence for drives that are not yet operational, target velocities for
//! those that are, then SYNC.
//!
//! Zero velocity is commanded when the executive is in safe mode, when the
//! command is older than its timeout, or when there is no command yet.

use speleo_hal::cia402::{self, DriveState};
use speleo_scheduler::{Context, Mode, Task};

use crate::bus::Bus;

pub struct DriveOutput {
    command_timeout_ns: u64,
}

impl DriveOutput {
    pub fn new(command_timeout_ns: u64) -> Self {
        DriveOutput { command_timeout_ns }
    }
}

impl Task<Bus> for DriveOutput {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let command = bus
            .command
            .get()
            .filter(|c| cx.time_ns.saturating_sub(c.stamp_ns) <= self.command_timeout_ns)
            .filter(|_| cx.mode == Mode::Nominal)
            .map(|c| c.value.wheel_speeds);
        let states = bus.drives.get().map(|d| d.value.wheels.map(|w| w.state));
        for i in 0..4 {
            let state = states.map_or(DriveState::NotReadyToSwitchOn, |s| s[i]);
            let controlword = state.next_enable_command();
            let velocity = match (state, command) {
                (DriveState::OperationEnabled, Some(w)) => (w[i] * 1000.0).round() as i32,
                _ => 0,
            };
            bus.can_tx
                .push(cia402::rpdo1(i as u8 + 1, controlword, velocity));
        }
        bus.can_tx.push(cia402::sync());
    }
}
