//! What became of each injected fault: when the health task found it,
//! whether the rover stopped, and when it was back to the nominal schedule
//! after the fault had cleared. Also counts findings when no fault was
//! injected (false alarms). Fed between frames; the report's `faults`
//! section.

use serde::Serialize;
use speleo_scheduler::Mode;

use super::FaultSpec;
use speleo_health::finding;

/// A finding this long after a fault's end still belongs to it (a silence
/// shows only after its timeout).
const DETECTION_TAIL_NS: u64 = 1_000_000_000;
/// Findings this long after a fault's end are its aftermath, not alarms.
const SETTLE_NS: u64 = 3_000_000_000;

#[derive(Clone, Debug, Serialize)]
pub struct FaultOutcome {
    pub spec: String,
    pub kind: &'static str,
    pub at_s: f64,
    pub duration_s: f64,
    /// From the fault's start (a clock jump's landing) to the first
    /// health finding that shows it.
    pub detected_after_ms: Option<f64>,
    /// The findings seen while it acted.
    pub findings: Vec<&'static str>,
    /// The safe schedule started while it acted.
    pub safe_stop: bool,
    /// From the fault's end to the nominal schedule again.
    pub recovered_after_ms: Option<f64>,
}

#[derive(Clone, Debug, Serialize)]
pub struct FaultFigures {
    pub injected: usize,
    pub detected: usize,
    pub detection_ms_max: Option<f64>,
    /// Switches to the safe schedule.
    pub safe_stops: u64,
    /// Faults after whose end the rover went back to the nominal schedule.
    pub recovered: usize,
    /// Findings raised with no injected fault acting or settling.
    pub false_alarms: u64,
    pub faults: Vec<FaultOutcome>,
    /// Every finding the health task raised and every stay in the safe
    /// schedule, with their times, whether faults were injected or not
    /// (the real rover's, a bench's).
    pub episodes: Vec<Episode>,
    /// Episodes past the log's capacity, not listed.
    pub episodes_dropped: u64,
}

/// A finding (or the safe schedule, `safe_mode`) from the frame it was
/// raised to the frame it cleared, in mission seconds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Episode {
    pub what: &'static str,
    pub from_s: f64,
    /// None: still in force at the end.
    pub until_s: Option<f64>,
}

/// Episodes kept: the log's memory is fixed at start-up.
const EPISODES: usize = 64;

struct Tracked {
    spec: FaultSpec,
    detected_ns: Option<u64>,
    findings: u16,
    safe_stop: bool,
    recovered_ns: Option<u64>,
}

pub struct FaultLog {
    tracked: Vec<Tracked>,
    last_mask: u16,
    last_mode: Mode,
    safe_stops: u64,
    false_alarms: u64,
    episodes: heapless::Vec<Episode, EPISODES>,
    episodes_dropped: u64,
}

impl FaultLog {
    pub fn new(faults: &[FaultSpec]) -> Self {
        FaultLog {
            tracked: faults
                .iter()
                .map(|f| Tracked {
                    spec: *f,
                    detected_ns: None,
                    findings: 0,
                    safe_stop: false,
                    recovered_ns: None,
                })
                .collect(),
            last_mask: 0,
            last_mode: Mode::Nominal,
            safe_stops: 0,
            false_alarms: 0,
            episodes: heapless::Vec::new(),
            episodes_dropped: 0,
        }
    }

    /// Open an episode of `what` at `t_s`.
    fn open(&mut self, what: &'static str, t_s: f64) {
        let e = Episode {
            what,
            from_s: t_s,
            until_s: None,
        };
        if self.episodes.push(e).is_err() {
            self.episodes_dropped += 1;
        }
    }

    /// Close the open episode of `what` at `t_s`.
    fn close(&mut self, what: &'static str, t_s: f64) {
        if let Some(e) = self
            .episodes
            .iter_mut()
            .rev()
            .find(|e| e.what == what && e.until_s.is_none())
        {
            e.until_s = Some(t_s);
        }
    }

    fn track_episodes(&mut self, t_ns: u64, findings: u16, mode: Mode) {
        let t_s = t_ns as f64 / 1e9;
        for (bit, name) in finding::NAMES {
            match (self.last_mask & bit != 0, findings & bit != 0) {
                (false, true) => self.open(name, t_s),
                (true, false) => self.close(name, t_s),
                _ => {}
            }
        }
        match (self.last_mode, mode) {
            (Mode::Nominal, Mode::Safe) => self.open("safe_mode", t_s),
            (Mode::Safe, Mode::Nominal) => self.close("safe_mode", t_s),
            _ => {}
        }
    }

    /// After each frame: its time, the health findings in force, the mode.
    pub fn observe(&mut self, t_ns: u64, findings: u16, mode: Mode) {
        self.track_episodes(t_ns, findings, mode);
        let rising = findings & !self.last_mask;
        if mode == Mode::Safe && self.last_mode == Mode::Nominal {
            self.safe_stops += 1;
        }
        let mut explained = false;
        for f in &mut self.tracked {
            let s = &f.spec;
            if t_ns < s.at_ns {
                continue;
            }
            let end = s.end_ns();
            if t_ns <= end + DETECTION_TAIL_NS {
                f.findings |= findings;
                // A jump is seen where the clock lands, not where it left.
                let from = if s.kind == super::FaultKind::ClockJump {
                    end
                } else {
                    s.at_ns
                };
                if f.detected_ns.is_none() && findings & s.kind.findings() != 0 {
                    f.detected_ns = Some(t_ns.saturating_sub(from));
                }
                if mode == Mode::Safe {
                    f.safe_stop = true;
                }
            }
            if t_ns <= end + SETTLE_NS {
                explained = true;
            }
            if f.safe_stop && f.recovered_ns.is_none() && t_ns >= end && mode == Mode::Nominal {
                f.recovered_ns = Some(t_ns - end);
            }
        }
        if rising != 0 && !explained {
            self.false_alarms += 1;
        }
        self.last_mask = findings;
        self.last_mode = mode;
    }

    pub fn figures(&self) -> FaultFigures {
        let ms = |ns: u64| ns as f64 * 1e-6;
        let faults: Vec<FaultOutcome> = self
            .tracked
            .iter()
            .map(|f| FaultOutcome {
                spec: f.spec.to_string(),
                kind: f.spec.kind.name(),
                at_s: f.spec.at_ns as f64 / 1e9,
                duration_s: f.spec.duration_ns as f64 / 1e9,
                detected_after_ms: f.detected_ns.map(ms),
                findings: finding::names(f.findings).collect(),
                safe_stop: f.safe_stop,
                recovered_after_ms: f.recovered_ns.map(ms),
            })
            .collect();
        FaultFigures {
            injected: faults.len(),
            detected: faults
                .iter()
                .filter(|f| f.detected_after_ms.is_some())
                .count(),
            detection_ms_max: faults
                .iter()
                .filter_map(|f| f.detected_after_ms)
                .reduce(f64::max),
            safe_stops: self.safe_stops,
            recovered: faults
                .iter()
                .filter(|f| f.recovered_after_ms.is_some())
                .count(),
            false_alarms: self.false_alarms,
            faults,
            episodes: self.episodes.to_vec(),
            episodes_dropped: self.episodes_dropped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use speleo_health::finding::*;

    const MS: u64 = 1_000_000;

    #[test]
    fn a_fault_is_detected_stopped_for_and_recovered_from() {
        let f = FaultSpec::parse("lidar-dropout@1+2").expect("spec");
        let mut log = FaultLog::new(&[f]);
        for k in 0..600u64 {
            let t = k * 10 * MS;
            let found = if (1_300..3_100).contains(&(t / MS)) {
                LIDAR_SILENT
            } else {
                0
            };
            let safe = (1_300..5_100).contains(&(t / MS));
            log.observe(t, found, if safe { Mode::Safe } else { Mode::Nominal });
        }
        let g = log.figures();
        assert_eq!((g.injected, g.detected, g.recovered), (1, 1, 1));
        assert_eq!(g.detection_ms_max, Some(300.0));
        assert_eq!(g.faults[0].recovered_after_ms, Some(2_100.0));
        assert_eq!(g.faults[0].findings, vec!["lidar_silent"]);
        assert_eq!((g.safe_stops, g.false_alarms), (1, 0));
        let e = |what, from_s, until_s| Episode {
            what,
            from_s,
            until_s: Some(until_s),
        };
        assert_eq!(
            g.episodes,
            vec![e("lidar_silent", 1.3, 3.1), e("safe_mode", 1.3, 5.1)]
        );
    }

    #[test]
    fn findings_with_no_fault_are_false_alarms() {
        let mut log = FaultLog::new(&[]);
        for (k, m) in [0, WHEEL, WHEEL, 0, CLOCK_JUMP].into_iter().enumerate() {
            log.observe(k as u64 * 10 * MS, m, Mode::Nominal);
        }
        let g = log.figures();
        assert_eq!(
            (g.false_alarms, g.detected, g.detection_ms_max),
            (2, 0, None)
        );
    }
}
