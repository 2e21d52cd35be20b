//! The control task: the driver (`speleo_control::Driver`) over the bus.
//! Each run takes the SLAM pose, the planner's newest plan and the serving
//! MLS map, and publishes the driver's wheel command.

use speleo_control::{ControlCounters, Driver, StopReason};
use speleo_scheduler::{Context, Task};

use crate::bus::Bus;

pub struct ControlTask {
    pub driver: Driver,
}

impl ControlTask {
    pub fn new(driver: Driver) -> Self {
        ControlTask { driver }
    }

    pub fn counters(&self) -> ControlCounters {
        self.driver.counters
    }

    /// Safety stops by reason.
    pub fn stops(&self) -> impl Iterator<Item = (StopReason, u64)> + '_ {
        self.driver.stops()
    }
}

impl Task<Bus> for ControlTask {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let Some(pose) = bus.slam.get() else {
            return;
        };
        let plan = bus.plan.get().map(|p| &p.value);
        let command = self
            .driver
            .step(cx.time_ns, &pose.value, plan, bus.surface.serving());
        bus.command.publish(cx.time_ns, command);
    }

    fn set_degraded(&mut self, degraded: bool) {
        self.driver.set_degraded(degraded);
    }

    fn retract(&mut self, bus: &mut Bus) {
        bus.command.retract();
    }
}
