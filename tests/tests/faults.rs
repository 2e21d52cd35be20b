//! Faults in a simulated mission: a drive that loses power (its heartbeat
//! stops) or reports a fault stops every wheel and puts the executive in
//! safe mode, with sensors still decoded.

use std::cell::RefCell;
use std::sync::atomic::AtomicBool;

use speleo_firmware::config::Config;
use speleo_firmware::mission::{self, Length, MissionInputs};
use speleo_firmware::record::RecorderTap;
use speleo_firmware::schedule_table;
use speleo_hal::sim::{SimHardware, SimParams, TruthProbe};
use speleo_hal::{CanBus, Hardware, ImuPort, LidarSource};
use speleo_scheduler::{Enforcement, Mode, VirtualClock};

enum Fault {
    PowerCut,
    DriveFault,
}

/// The simulated rover with one fault injected into drive 2 at `at_ns`.
struct Faulty {
    sim: SimHardware,
    at_ns: u64,
    fault: Fault,
    done: bool,
}

impl Hardware for Faulty {
    fn advance_to(&mut self, now_ns: u64) {
        if now_ns >= self.at_ns && !self.done {
            self.done = true;
            match self.fault {
                Fault::PowerCut => self.sim.drives_mut().set_powered(1, false),
                Fault::DriveFault => self.sim.drives_mut().inject_fault(1),
            }
        }
        self.sim.advance_to(now_ns);
    }
    fn lidar(&mut self) -> &mut dyn LidarSource {
        self.sim.lidar()
    }
    fn imu(&mut self) -> &mut dyn ImuPort {
        self.sim.imu()
    }
    fn can(&mut self) -> &mut dyn CanBus {
        self.sim.can()
    }
}

/// Run 1000 frames (10 s) of the default mission schedule for `cfg`.
fn run_mission(cfg: &Config, hw: &mut dyn Hardware, truth: &TruthProbe) -> mission::MissionResult {
    let tap = RefCell::new(RecorderTap::new(0, None, 4096));
    let stop = AtomicBool::new(false);
    mission::run(
        MissionInputs {
            cfg,
            schedule: schedule_table::build(cfg).expect("schedule"),
            length: Length::Frames(1000),
            enforcement: Enforcement::CountOnly,
            truth: Some(truth.clone()),
            stop: &stop,
            progress: None,
        },
        hw,
        &tap,
        VirtualClock::new(cfg.executive.minor_frame_us),
    )
    .expect("mission runs")
}

/// 5 s healthy, then 5 s with `fault` in drive 2.
fn fly(fault: Fault) -> (mission::MissionResult, TruthProbe) {
    let sim = SimHardware::new(&SimParams::default()).expect("sim");
    let truth = sim.truth_probe();
    let mut hw = Faulty {
        sim,
        at_ns: 5_000_000_000,
        fault,
        done: false,
    };
    (run_mission(&Config::default(), &mut hw, &truth), truth)
}

/// Slower than this is standing still (the cruise speed is 0.4 m/s).
const STOPPED: f64 = 0.004;

#[test]
fn a_drive_that_loses_power_stops_the_rover() {
    let (r, truth) = fly(Fault::PowerCut);
    let t = truth.get();
    assert_eq!(r.mode, Mode::Safe, "safe mode after the heartbeat was lost");
    assert!(
        t.forward_speed().abs() < STOPPED,
        "still moving at {} m/s",
        t.forward_speed()
    );
    assert!(
        t.position[0].hypot(t.position[1]) > 1.0,
        "it had driven before the fault"
    );
    // Sensors are still decoded in safe mode.
    let imu = r
        .tasks
        .iter()
        .find(|t| t.name == "imu_driver")
        .expect("task");
    assert_eq!(imu.runs, 1000);
}

#[test]
fn a_drive_fault_stops_the_rover() {
    let (r, truth) = fly(Fault::DriveFault);
    assert_eq!(r.mode, Mode::Safe);
    assert!(
        truth.get().forward_speed().abs() < STOPPED,
        "{}",
        truth.get().forward_speed()
    );
}

#[test]
fn commands_that_go_stale_hold_the_wheels() {
    // The path follower runs only every 300 ms: longer than the 100 ms
    // freshness limit of wheel commands, so the wheels are held between runs.
    let cfg = Config::from_toml("[tasks.control]\ndivisor = 30\noffset = 1\n").expect("config");
    let mut sim = SimHardware::new(&SimParams::default()).expect("sim");
    let truth = sim.truth_probe();
    let r = run_mission(&cfg, &mut sim, &truth);
    // Stale commands are not a failure: no safe mode, but little progress
    // (each command drives for 100 ms out of every 300 ms at most).
    assert_eq!(r.mode, Mode::Nominal);
    let t = truth.get();
    assert!(
        t.position[0].hypot(t.position[1]) < 0.5 * 0.4 * 10.0,
        "{} m",
        t.position[0].hypot(t.position[1])
    );
}
