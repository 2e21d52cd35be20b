//! Faults in a simulated mission: a drive that loses power (its heartbeat
//! stops) or reports a fault stops every wheel and puts the executive in
//! safe mode, with sensors still decoded; and every kind of `--fault` is
//! found by the health task, stops the rover, and is recovered from once
//! it clears, with the recording complete and replaying identically.

use std::cell::RefCell;
use std::sync::atomic::AtomicBool;

use speleo_firmware::config::Config;
use speleo_firmware::faults::inject::{FaultClock, FaultyHardware};
use speleo_firmware::faults::log::FaultOutcome;
use speleo_firmware::faults::{self, FaultKind};
use speleo_firmware::mission::{self, Length, MissionInputs};
use speleo_firmware::record::RecorderTap;
use speleo_firmware::schedule_table;
use speleo_hal::{CanBus, Hardware, ImuPort, LidarSource};
use speleo_scheduler::{Enforcement, FrameClock, Mode, VirtualClock};
use speleo_tests::{read_json, replay, sim_with_config, Scratch};
use speleo_twin::{TruthProbe, TwinHardware, TwinParams};

enum Fault {
    PowerCut,
    DriveFault,
}

/// The simulated rover with one fault injected into drive 2 at `at_ns`.
struct Faulty {
    sim: TwinHardware,
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
    run_frames(
        cfg,
        hw,
        truth,
        1000,
        VirtualClock::new(cfg.executive.minor_frame_us),
    )
}

fn run_frames<C: FrameClock>(
    cfg: &Config,
    hw: &mut dyn Hardware,
    truth: &TruthProbe,
    frames: u64,
    clock: C,
) -> mission::MissionResult {
    let mut tap = RecorderTap::new(None, 4096);
    tap.begin(0);
    let tap = RefCell::new(tap);
    let stop = AtomicBool::new(false);
    mission::run(
        MissionInputs {
            cfg,
            schedule: schedule_table::build(cfg).expect("schedule"),
            length: Length::Frames(frames),
            enforcement: Enforcement::CountOnly,
            truth: Some(truth.clone()),
            stop: &stop,
            progress: None,
            replayed_timing: &[],
        },
        hw,
        &tap,
        clock,
    )
    .expect("mission runs")
}

/// 5 s healthy, then 5 s with `fault` in drive 2.
fn fly(fault: Fault) -> (mission::MissionResult, TruthProbe) {
    let sim = TwinHardware::new(&TwinParams::default()).expect("sim");
    let truth = sim.truth_probe();
    let mut hw = Faulty {
        sim,
        at_ns: 5_000_000_000,
        fault,
        done: false,
    };
    // The route: a known path to drive when the fault strikes.
    let mut cfg = Config::default();
    cfg.exploration.enabled = false;
    (run_mission(&cfg, &mut hw, &truth), truth)
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
    let cfg = Config::from_toml(
        "[exploration]\nenabled = false\n[tasks.control]\ndivisor = 30\noffset = 1\n",
    )
    .expect("config");
    let mut sim = TwinHardware::new(&TwinParams::default()).expect("sim");
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

/// Every kind of fault but the LiDAR's and the overrun storm (tested
/// below), one after another, each for 2 s (the jump: 1 s), 6 s apart.
const SEQUENCE: &str = r#"[exploration]
enabled = false
[sim]
lidar = false
faults = ["imu-garbage@4+2", "imu-dropout@10+2", "stuck-wheel@16+2:3", "wheel-slip@22+2:2",
          "drive-fault@28+2:2", "can-bus-off@34+2", "clock-jump@40+1"]
"#;
const SEQUENCE_S: f64 = 46.0;

/// Simulated hardware with faults, keeping the true track at every frame.
struct Watched<'a> {
    hw: FaultyHardware<'a, TwinHardware>,
    truth: TruthProbe,
    /// (time, forward speed, position).
    track: Vec<(u64, f64, [f64; 3])>,
}

impl Hardware for Watched<'_> {
    fn advance_to(&mut self, now_ns: u64) {
        self.hw.advance_to(now_ns);
        let t = self.truth.get();
        if self.track.last().is_none_or(|l| l.0 < now_ns) {
            self.track.push((now_ns, t.forward_speed(), t.position));
        }
    }
    fn lidar(&mut self) -> &mut dyn LidarSource {
        self.hw.lidar()
    }
    fn imu(&mut self) -> &mut dyn ImuPort {
        self.hw.imu()
    }
    fn can(&mut self) -> &mut dyn CanBus {
        self.hw.can()
    }
}

/// The true track's sample at or after `t_ns`.
fn at(track: &[(u64, f64, [f64; 3])], t_ns: u64) -> (f64, [f64; 3]) {
    let i = track.partition_point(|s| s.0 < t_ns).min(track.len() - 1);
    (track[i].1, track[i].2)
}

const S: u64 = 1_000_000_000;

#[test]
fn every_fault_is_found_stops_the_rover_and_is_recovered_from() {
    let cfg = Config::from_toml(SEQUENCE).expect("config");
    let specs = faults::parse_all(&cfg.sim.faults).expect("faults");
    let mut sim = TwinHardware::new(&TwinParams::default()).expect("sim");
    let truth = sim.truth_probe();
    let mut hw = Watched {
        hw: FaultyHardware::new(&mut sim, &specs, false),
        truth: truth.clone(),
        track: Vec::new(),
    };
    let clock = FaultClock::new(VirtualClock::new(cfg.executive.minor_frame_us), &specs);
    let frames = (SEQUENCE_S * 100.0) as u64;
    let frames = frames - clock.skipped_within(frames);
    let r = run_frames(&cfg, &mut hw, &truth, frames, clock);
    let track = hw.track;
    let f = &r.faults;
    assert_eq!(f.injected, 7);
    assert_eq!(f.false_alarms, 0, "{f:#?}");
    assert_eq!(r.mode, Mode::Nominal, "back to nominal at the end");
    for (spec, o) in specs.iter().zip(&f.faults) {
        let o: &FaultOutcome = o;
        let found = o
            .detected_after_ms
            .unwrap_or_else(|| panic!("{} was not found: {o:?}", o.spec));
        assert!(found <= 500.0, "{}: found after {found} ms", o.spec);
        assert!(o.safe_stop, "{}: no safe stop", o.spec);
        let back = o
            .recovered_after_ms
            .unwrap_or_else(|| panic!("{} was not recovered from: {o:?}", o.spec));
        assert!(back <= 3_000.0, "{}: back after {back} ms", o.spec);
        // Standing still from a second after it was found (braking from
        // 0.4 m/s takes most of it; a jump is found where the clock lands):
        // within a centimetre over the next half second, and not moving at
        // its end. A leg-wheel that stopped on a leg's tip may tip over and
        // roll the body a few millimetres as it settles.
        let from = if spec.kind == FaultKind::ClockJump {
            spec.end_ns()
        } else {
            spec.at_ns
        };
        let still = from + (found as u64 + 1_000) * 1_000_000;
        let (_, p0) = at(&track, still);
        let (v, p1) = at(&track, still + S / 2);
        let crept = (p1[0] - p0[0]).hypot(p1[1] - p0[1]);
        assert!(crept < 0.01, "{}: {crept} m from {still} ns", o.spec);
        assert!(
            v.abs() < STOPPED,
            "{}: {v} m/s at {still} ns + 0.5 s",
            o.spec
        );
        // Driving on once recovered.
        let going = spec.end_ns() + (back as u64 + 500) * 1_000_000;
        let (_, p0) = at(&track, going);
        let (_, p1) = at(&track, going + 2 * S);
        let moved = (p1[0] - p0[0]).hypot(p1[1] - p0[1]);
        assert!(moved > 0.3, "{}: {moved} m in 2 s after recovery", o.spec);
    }
}

/// A recorded simulation with configuration `cfg`: its report, after
/// checking that the recording is complete (nothing dropped, every message
/// written in the file). The scratch directory holds `a.mcap`.
fn recorded_sim(s: &Scratch, cfg: &str, seconds: f64) -> serde_json::Value {
    let path = s.path("faults.toml");
    std::fs::write(&path, cfg).expect("config");
    let (log, report) = (s.path("a.mcap"), s.path("a.json"));
    sim_with_config(1, seconds, Some(&path), Some(&log), Some(&report));
    let r = read_json(&report);
    assert_eq!(r["recorder"]["dropped_no_buffer"], 0);
    let bytes = std::fs::read(&log).expect("recording");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("present");
    let in_file = summary.stats.expect("statistics").message_count;
    assert_eq!(r["recorder"]["written"].as_u64(), Some(in_file));
    r
}

/// The one fault of report `r`: found within `ms`, stopped for, recovered from.
fn found_stopped_recovered(r: &serde_json::Value, ms: f64) -> &serde_json::Value {
    let o = &r["faults"]["faults"][0];
    let found = o["detected_after_ms"].as_f64();
    assert!(found.is_some_and(|t| t <= ms), "{o}");
    assert_eq!(o["safe_stop"], true);
    assert!(o["recovered_after_ms"].as_f64().is_some(), "{o}");
    assert_eq!(r["scheduler"]["mode_at_end"], "nominal");
    o
}

#[test]
fn a_recording_through_every_fault_is_complete_and_replays_identically() {
    let s = Scratch::new();
    let r = recorded_sim(&s, SEQUENCE, SEQUENCE_S);
    assert_eq!(r["faults"]["detected"], 7);
    assert_eq!(r["faults"]["recovered"], 7);
    // The devices' faults are in the recorded bytes; the bus-off errors
    // and the jump are injected again.
    assert_eq!(
        replay(&s.path("a.mcap"), None),
        std::process::ExitCode::SUCCESS
    );
}

#[test]
fn a_lidar_dropout_is_found_and_recovered_from_and_replays_identically() {
    let s = Scratch::new();
    let cfg = "[sim]\nworld = \"flat\"\nfaults = [\"lidar-dropout@4+2\"]\n";
    let r = recorded_sim(&s, cfg, 10.0);
    let o = found_stopped_recovered(&r, 500.0);
    assert_eq!(o["findings"][0], "lidar_silent");
    assert_eq!(r["faults"]["false_alarms"], 0);
    assert_eq!(
        replay(&s.path("a.mcap"), None),
        std::process::ExitCode::SUCCESS
    );
}

#[test]
fn an_overrun_storm_is_found_when_budgets_are_enforced() {
    let s = Scratch::new();
    // The storm's 3 ms device polls against the io task's 400 us budget.
    // Overruns skip runs of the io task, never recorded messages.
    let cfg = "[executive]\nenforce_policies_in_sim = true\n[sim]\nlidar = false\nfaults = [\"overrun-storm@3+2\"]\n";
    let r = recorded_sim(&s, cfg, 9.0);
    found_stopped_recovered(&r, 1_000.0);
}
