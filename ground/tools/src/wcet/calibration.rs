//! `speleo wcet --calibrate`: the planner's units per step, phase by phase,
//! from the step times a wcet run measured. Each phase gets as many units
//! as fill 90 % of the task's window at the p99.9 a unit of it took over all
//! the scenarios' steps of it; phases with too few steps for a p99.9 to
//! mean something keep their configured units. The times are the frame
//! thread's CPU time: the work's own cost. On a shared machine the wall
//! clock adds whatever preempted the thread, and sized by it the steps
//! shrank for a neighbour's load (a validate unit's p99.9 was 318 us on the
//! wall clock, 122 us on the CPU clock, in one run).

use std::fmt::Write;

use speleo_scheduler::histogram::Histogram;

use super::ScenarioReport;
use speleo_firmware::config::{PlannerStepUnits, MAX_STEP_UNITS, STEP_PHASES};

/// Share of the window the calibrated steps fill at their p99.9.
const FILL: f64 = 0.9;
/// Fewest steps of a phase for its p99.9 to count (with fewer it is the
/// slowest step or nearly, and one preemption decides it).
pub const MIN_STEPS: u64 = 1000;

/// A phase's steps pooled over the scenarios that ran it with the same
/// units.
#[derive(Debug, PartialEq)]
pub struct PhaseMeasure {
    pub phase: &'static str,
    /// The scenarios pooled.
    pub scenarios: Vec<String>,
    pub steps: u64,
    pub step_p999_us: f64,
    /// Units of the measured steps.
    pub units_run: u32,
}

impl PhaseMeasure {
    pub fn unit_us(&self) -> f64 {
        self.step_p999_us / self.units_run.max(1) as f64
    }
}

/// The calibrated table and what it came from.
#[derive(Debug, PartialEq)]
pub struct PlannerCalibration {
    pub units: PlannerStepUnits,
    pub window_us: u32,
    pub measured: Vec<PhaseMeasure>,
}

/// The units per phase for `window_us`, from the scenarios' step times
/// pooled (a p99.9 over every step of the phase, not the worst scenario's:
/// one preempted step among a thousand would decide that);
/// `current` for the phases with fewer than [`MIN_STEPS`] steps. None when
/// nothing was measured.
pub fn planner_calibration(
    scenarios: &[ScenarioReport],
    current: PlannerStepUnits,
    window_us: u32,
) -> Option<PlannerCalibration> {
    let mut units = current.as_array();
    let mut measured = Vec::new();
    for (i, &phase) in STEP_PHASES.iter().enumerate() {
        // Pooled by the units the steps did (one group unless the
        // scenarios configure the planner differently).
        let mut groups: Vec<(u32, Histogram, Vec<String>)> = Vec::new();
        for s in scenarios {
            let Some(t) = s.planner_step_us.as_ref().and_then(|m| m.get(phase)) else {
                continue;
            };
            if t.units == 0 || t.cpu_histogram.count() == 0 {
                continue;
            }
            match groups.iter_mut().find(|g| g.0 == t.units) {
                Some(g) => {
                    g.1.merge(&t.cpu_histogram);
                    g.2.push(s.name.clone());
                }
                None => groups.push((t.units, t.cpu_histogram.clone(), vec![s.name.clone()])),
            }
        }
        let worst = groups
            .into_iter()
            .filter(|g| g.1.count() >= MIN_STEPS)
            .map(|(units_run, h, scenarios)| PhaseMeasure {
                phase,
                scenarios,
                steps: h.count(),
                step_p999_us: h.quantile_ns(0.999) as f64 / 1000.0,
                units_run,
            })
            .max_by(|a, b| a.unit_us().total_cmp(&b.unit_us()));
        if let Some(w) = worst {
            let fits = (FILL * window_us as f64 / w.unit_us().max(1e-3)).floor();
            units[i] = fits.clamp(1.0, MAX_STEP_UNITS as f64) as u32;
            measured.push(w);
        }
    }
    if measured.is_empty() {
        return None;
    }
    Some(PlannerCalibration {
        units: PlannerStepUnits::from_array(units),
        window_us,
        measured,
    })
}

impl PlannerCalibration {
    /// A configuration holding the table, with the figures as comments.
    pub fn to_toml(&self) -> String {
        let mut s = format!(
            "# Written by `speleo wcet --calibrate`: each phase of a planner step\n\
             # gets the units that fill {:.0} % of the {} us window at the p99.9 (CPU time) a\n\
             # unit of it took over all the scenarios (phases with fewer than {}\n\
             # steps keep their units).\n",
            FILL * 100.0,
            self.window_us,
            MIN_STEPS
        );
        for m in &self.measured {
            let _ = writeln!(
                s,
                "#   {}: {:.0} us at p99.9 for {} units over {} steps ({}), {:.1} us a unit",
                m.phase,
                m.step_p999_us,
                m.units_run,
                m.steps,
                m.scenarios.join(", "),
                m.unit_us()
            );
        }
        s.push_str("[planner.step_units]\n");
        for (name, v) in STEP_PHASES.iter().zip(self.units.as_array()) {
            let _ = writeln!(s, "{name} = {v}");
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use speleo_firmware::config::Config;
    use speleo_firmware::planner_figures::StepTimes;

    /// A phase's steps: how many, at what time, how many of them slow and
    /// how slow, and their units.
    struct Steps {
        phase: &'static str,
        steps: u64,
        us: u64,
        slow: u64,
        slow_us: u64,
        units: u32,
    }

    fn steps(phase: &'static str, steps: u64, us: u64, units: u32) -> Steps {
        Steps {
            phase,
            steps,
            us,
            slow: 0,
            slow_us: 0,
            units,
        }
    }

    fn scenario(name: &str, phases: &[Steps]) -> ScenarioReport {
        let figures = phases
            .iter()
            .map(|p| {
                let mut h = Histogram::new();
                for i in 0..p.steps {
                    h.record(1000 * if i < p.slow { p.slow_us } else { p.us });
                }
                let t = StepTimes {
                    steps: h.count(),
                    units: p.units,
                    p50_us: h.quantile_ns(0.5) as f64 / 1000.0,
                    p999_us: h.quantile_ns(0.999) as f64 / 1000.0,
                    max_us: h.max_ns() as f64 / 1000.0,
                    cpu_p999_us: h.quantile_ns(0.999) as f64 / 1000.0,
                    cpu_histogram: h,
                };
                (p.phase, t)
            })
            .collect();
        ScenarioReport {
            name: name.into(),
            about: String::new(),
            world: String::new(),
            sim_time_s: 0.0,
            wall_time_s: 0.0,
            memory: None,
            planner_step_us: Some(figures),
            tasks: Vec::new(),
            pass: true,
        }
    }

    #[test]
    fn each_phase_fills_90_percent_of_the_window_at_its_pooled_p999() {
        let preempted = Steps {
            slow: 2,
            slow_us: 1_600,
            ..steps("search", 1_000, 400, 16)
        };
        let both = [
            scenario("a", &[preempted, steps("validate", 2_000, 1_900, 24)]),
            scenario(
                "b",
                &[
                    steps("search", 9_000, 400, 16),
                    steps("prepare", 1_000, 450, 10),
                ],
            ),
        ];
        let current = PlannerStepUnits::default();
        let c = planner_calibration(&both, current, 1_000).expect("measured");
        // search: two slow steps in 10,000 are not its p99.9 (they are
        // a's alone): 400 us (the bucket's 409.6) for 16 units, 35 fill
        // 900 us. validate: 79.2 us a unit, 11. prepare: 45 us a unit
        // (every step took the maximum, which is exact) measured at 10
        // units, 20.
        assert_eq!(c.units.search, 35);
        assert_eq!(c.units.validate, 11);
        assert_eq!(c.units.prepare, 20);
        assert_eq!(c.units.grow, current.grow, "not measured: kept");
        let search = c
            .measured
            .iter()
            .find(|m| m.phase == "search")
            .expect("search");
        assert_eq!((search.steps, search.scenarios.len()), (10_000, 2));
        let back = Config::from_toml(&c.to_toml()).expect("the calibration is a configuration");
        assert_eq!(back.planner.step_units, c.units);
    }

    #[test]
    fn nothing_measured_gives_nothing() {
        assert!(planner_calibration(&[], PlannerStepUnits::default(), 1_000).is_none());
        let unmeasured = [scenario("a", &[steps("search", 1_000, 500, 0)])];
        assert!(planner_calibration(&unmeasured, PlannerStepUnits::default(), 1_000).is_none());
        let few = [scenario("a", &[steps("search", MIN_STEPS - 1, 5_000, 16)])];
        assert!(
            planner_calibration(&few, PlannerStepUnits::default(), 1_000).is_none(),
            "too few steps for a p99.9"
        );
    }

    #[test]
    fn a_unit_slower_than_the_window_still_gets_one() {
        let slow = [scenario("a", &[steps("validate", 1_000, 5_000, 2)])];
        let c = planner_calibration(&slow, PlannerStepUnits::default(), 1_000).expect("measured");
        assert_eq!(c.units.validate, 1);
    }
}
