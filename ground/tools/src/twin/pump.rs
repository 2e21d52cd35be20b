//! The twin's real-time loop: every millisecond of its own monotonic clock
//! the world moves on to the present, the devices' output due by then goes
//! out on the wires, and what the flight binary wrote reaches the devices.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use speleo_hal::Hardware;
use speleo_scheduler::clock::FrameClock;
use speleo_scheduler::realtime::MonotonicClock;
use speleo_twin::TwinHardware;

use super::links::Links;

/// The loop's period: the physics step.
const STEP_US: u32 = 1000;
/// The true pose is recorded this often (100 Hz).
const TRUTH_EVERY_STEPS: u64 = 10;

/// A stretch of twin time during which the LiDAR is unplugged.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Unplug {
    pub at_s: f64,
    pub for_s: f64,
}

impl Unplug {
    /// `AT:FOR` in seconds, as `--unplug-lidar 30:5` gives it.
    pub fn parse(s: &str) -> Result<Unplug, String> {
        let bad = || format!("--unplug-lidar {s}: expected AT:SECONDS, e.g. 30:5");
        let (a, b) = s.split_once(':').ok_or_else(bad)?;
        let (at_s, for_s) = (
            a.trim().parse::<f64>().map_err(|_| bad())?,
            b.trim().parse::<f64>().map_err(|_| bad())?,
        );
        if !(at_s.is_finite() && for_s.is_finite() && at_s >= 0.0 && for_s > 0.0) {
            return Err(bad());
        }
        Ok(Unplug { at_s, for_s })
    }

    fn covers(&self, t_s: f64) -> bool {
        t_s >= self.at_s && t_s < self.at_s + self.for_s
    }
}

/// What the loop did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PumpFigures {
    /// Twin time run, s.
    pub seconds: f64,
    pub steps: u64,
    /// Steps skipped because the loop fell a whole step behind.
    pub steps_slipped: u64,
    /// Distance the rover truly drove, m.
    pub truth_distance_m: f64,
    /// The true pose at the end: x, y, z (m) and yaw (rad).
    pub truth_end: [f64; 4],
    /// The true pose at the start.
    pub truth_start: [f64; 4],
    /// The rover was wrecked in a fall: the world ended there.
    pub wrecked: bool,
}

fn pose4(g: &speleo_twin::GroundTruth) -> [f64; 4] {
    [g.position[0], g.position[1], g.position[2], g.yaw()]
}

/// Run until `stop` is set or `length` has passed.
pub fn run(
    hw: &mut TwinHardware,
    links: &mut Links,
    length: Option<Duration>,
    stop: &AtomicBool,
    unplug: &[Unplug],
) -> Result<PumpFigures, String> {
    let mut clock = MonotonicClock::new(STEP_US);
    let end_ns = length.map(|d| d.as_nanos() as u64);
    let first = hw.ground_truth();
    let mut fig = PumpFigures {
        truth_start: pose4(&first),
        ..Default::default()
    };
    let mut last = first.position;
    clock.start();
    // The recording's times are Unix times from here, as the flight
    // binary's count from its first frame: the two tracks line up.
    if let Some(t) = &mut links.tape {
        t.begin(speleo_scheduler::realtime::unix_now_ns());
    }
    let mut next = 0u64;
    while !stop.load(Ordering::Relaxed) {
        let step = clock.wait_frame(next);
        fig.steps_slipped += step - next;
        next = step + 1;
        let now = clock.frame_time_ns(step);
        if end_ns.is_some_and(|e| now >= e) {
            break;
        }
        hw.advance_to(now);
        let t_s = now as f64 * 1e-9;
        links.set_lidar_unplugged(unplug.iter().any(|u| u.covers(t_s)));
        links.deliver(hw, now)?;
        links.collect(hw, now)?;
        fig.steps += 1;
        if step.is_multiple_of(TRUTH_EVERY_STEPS) {
            let g = hw.ground_truth();
            let d: f64 = (0..3).map(|i| (g.position[i] - last[i]).powi(2)).sum();
            fig.truth_distance_m += d.sqrt();
            last = g.position;
            fig.truth_end = pose4(&g);
            if let Some(t) = &mut links.tape {
                t.truth(now, g.position, g.orientation);
            }
        }
        fig.seconds = t_s;
        if hw.world_over() {
            fig.wrecked = true;
            break;
        }
    }
    Ok(fig)
}
