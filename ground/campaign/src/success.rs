//! What makes one simulated mission a success, each part named, and the
//! cause of a failure.

use serde::{Deserialize, Serialize};

/// The thresholds a mission is judged against (`[sim.success]`). The
/// defaults are the whole-cave mission's goals; a scenario case sets its
/// own (a reach instead of the cave's coverage).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SuccessCriteria {
    /// The rover ends this close to where it started, m.
    pub home_within_m: f64,
    /// Fraction of the world's reachable floor explored (0: not judged).
    pub min_coverage: f64,
    /// The true track goes at least this far from the start, m (0: not
    /// judged): "passes the hard place and explores beyond it".
    pub min_reach_m: f64,
}

impl Default for SuccessCriteria {
    fn default() -> Self {
        SuccessCriteria {
            home_within_m: 0.5,
            min_coverage: 0.9,
            min_reach_m: 0.0,
        }
    }
}

impl SuccessCriteria {
    /// Refuses a threshold out of range, naming the key under `prefix`.
    pub fn validate(&self, prefix: &str) -> Result<(), String> {
        let check = |key: &str, v: f64, lo: f64, hi: f64| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(format!("{prefix}.{key} = {v}: must lie within {lo}..={hi}"))
            }
        };
        check("home_within_m", self.home_within_m, 0.0, 1e4)?;
        check("min_coverage", self.min_coverage, 0.0, 1.0)?;
        check("min_reach_m", self.min_reach_m, 0.0, 1e5)
    }
}

/// What a finished simulated mission measured, as the judge reads it.
#[derive(Clone, Debug, Default)]
pub struct MissionFacts {
    /// The exploration's state at the end: `finished`, `stranded`,
    /// `exploring` or `returning`.
    pub state: String,
    /// Whether the mission ended before its time limit ran out.
    pub ended_before_limit: bool,
    pub home_error_m: Option<f64>,
    pub coverage: Option<f64>,
    pub reach_m: Option<f64>,
    pub collisions: u64,
    pub falls: u64,
    pub wrecked: bool,
}

/// Why a mission failed: the first cause in the order the fields of
/// `Criteria` list them, so each failure has exactly one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FailureCause {
    /// The process died or the tool could not run it (campaigns only).
    Crash,
    /// The process ran past its wall-time limit and was killed (campaigns only).
    Hang,
    /// A fall wrecked the rover or it fell.
    Fall,
    Collision,
    /// The rover could not move any more.
    Stranded,
    /// The mission's time ran out before it ended.
    OutOfTime,
    /// It ended away from home.
    NotHome,
    /// It came home without exploring what it should have.
    GaveUpEarly,
}

impl FailureCause {
    pub const ALL: [FailureCause; 8] = [
        FailureCause::Crash,
        FailureCause::Hang,
        FailureCause::Fall,
        FailureCause::Collision,
        FailureCause::Stranded,
        FailureCause::OutOfTime,
        FailureCause::NotHome,
        FailureCause::GaveUpEarly,
    ];

    /// The name the reports use.
    pub fn name(self) -> &'static str {
        match self {
            FailureCause::Crash => "crash",
            FailureCause::Hang => "hang",
            FailureCause::Fall => "fall",
            FailureCause::Collision => "collision",
            FailureCause::Stranded => "stranded",
            FailureCause::OutOfTime => "out_of_time",
            FailureCause::NotHome => "not_home",
            FailureCause::GaveUpEarly => "gave_up_early",
        }
    }
}

/// Each part of success, true when met.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Criteria {
    pub no_wreck: bool,
    pub no_fall: bool,
    pub no_collision: bool,
    /// The exploration ended on its own (not stranded, not cut off).
    pub finished: bool,
    pub within_time: bool,
    pub home: bool,
    pub coverage: bool,
    pub reach: bool,
}

impl Criteria {
    /// The parts' names, in the order `parts` lists them.
    pub const NAMES: [&'static str; 8] = [
        "no_wreck",
        "no_fall",
        "no_collision",
        "finished",
        "within_time",
        "home",
        "coverage",
        "reach",
    ];

    /// The parts by name, in order.
    pub fn parts(&self) -> [(&'static str, bool); 8] {
        let [a, b, c, d, e, f, g, h] = Self::NAMES;
        [
            (a, self.no_wreck),
            (b, self.no_fall),
            (c, self.no_collision),
            (d, self.finished),
            (e, self.within_time),
            (f, self.home),
            (g, self.coverage),
            (h, self.reach),
        ]
    }
}

/// The verdict on one mission: the report's `success`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Success {
    pub passed: bool,
    pub criteria: Criteria,
    /// Absent when the mission passed.
    pub failure: Option<FailureCause>,
    /// The thresholds it was judged against.
    pub against: SuccessCriteria,
}

/// Judges a mission. A figure the mission could not measure (no ground
/// truth) fails its part.
pub fn judge(f: &MissionFacts, c: &SuccessCriteria) -> Success {
    let criteria = Criteria {
        no_wreck: !f.wrecked,
        no_fall: f.falls == 0,
        no_collision: f.collisions == 0,
        finished: f.state == "finished",
        within_time: f.ended_before_limit,
        home: f.home_error_m.is_some_and(|e| e <= c.home_within_m),
        coverage: c.min_coverage <= 0.0 || f.coverage.is_some_and(|v| v >= c.min_coverage),
        reach: c.min_reach_m <= 0.0 || f.reach_m.is_some_and(|v| v >= c.min_reach_m),
    };
    let failure = if !criteria.no_wreck || !criteria.no_fall {
        Some(FailureCause::Fall)
    } else if !criteria.no_collision {
        Some(FailureCause::Collision)
    } else if f.state == "stranded" {
        Some(FailureCause::Stranded)
    } else if !criteria.finished || !criteria.within_time {
        Some(FailureCause::OutOfTime)
    } else if !criteria.home {
        Some(FailureCause::NotHome)
    } else if !criteria.coverage || !criteria.reach {
        Some(FailureCause::GaveUpEarly)
    } else {
        None
    };
    Success {
        passed: failure.is_none(),
        criteria,
        failure,
        against: c.clone(),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a broken fixture fails the test where it breaks
mod tests {
    use super::*;

    fn good() -> MissionFacts {
        MissionFacts {
            state: "finished".into(),
            ended_before_limit: true,
            home_error_m: Some(0.3),
            coverage: Some(0.95),
            reach_m: Some(120.0),
            ..Default::default()
        }
    }

    #[test]
    fn a_mission_home_with_the_cave_explored_passes() {
        let s = judge(&good(), &SuccessCriteria::default());
        assert!(s.passed);
        assert_eq!(s.failure, None);
        assert!(s.criteria.parts().iter().all(|(_, ok)| *ok));
    }

    #[test]
    fn each_failure_has_one_cause_the_worst_first() {
        let c = SuccessCriteria::default();
        let mut f = good();
        f.coverage = Some(0.5);
        assert_eq!(judge(&f, &c).failure, Some(FailureCause::GaveUpEarly));
        f.home_error_m = Some(0.6);
        assert_eq!(judge(&f, &c).failure, Some(FailureCause::NotHome));
        f.state = "returning".into();
        f.ended_before_limit = false;
        assert_eq!(judge(&f, &c).failure, Some(FailureCause::OutOfTime));
        f.state = "stranded".into();
        f.ended_before_limit = true;
        assert_eq!(judge(&f, &c).failure, Some(FailureCause::Stranded));
        f.collisions = 2;
        assert_eq!(judge(&f, &c).failure, Some(FailureCause::Collision));
        f.wrecked = true;
        let s = judge(&f, &c);
        assert_eq!(s.failure, Some(FailureCause::Fall));
        assert!(!s.passed);
        assert!(!s.criteria.no_wreck && !s.criteria.home && !s.criteria.coverage);
    }

    #[test]
    fn a_scenario_is_judged_on_its_reach_not_the_caves_coverage() {
        let c = SuccessCriteria {
            min_coverage: 0.0,
            min_reach_m: 15.0,
            ..Default::default()
        };
        let mut f = good();
        f.coverage = Some(0.1);
        f.reach_m = Some(16.0);
        assert!(judge(&f, &c).passed);
        f.reach_m = Some(14.0);
        assert_eq!(judge(&f, &c).failure, Some(FailureCause::GaveUpEarly));
        f.reach_m = None;
        assert!(!judge(&f, &c).criteria.reach);
    }

    #[test]
    fn an_unmeasured_figure_fails_its_part() {
        let mut f = good();
        f.home_error_m = None;
        f.coverage = None;
        let s = judge(&f, &SuccessCriteria::default());
        assert!(!s.criteria.home && !s.criteria.coverage);
        assert_eq!(s.failure, Some(FailureCause::NotHome));
    }

    #[test]
    fn thresholds_out_of_range_are_refused_by_name() {
        let c = SuccessCriteria {
            min_coverage: 1.5,
            ..Default::default()
        };
        let e = c.validate("sim.success").unwrap_err();
        assert!(e.contains("sim.success.min_coverage"), "{e}");
    }
}
