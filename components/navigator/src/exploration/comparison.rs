//! A validated plan's real track against the internal simulation's
//! prediction of it: the RMSE of each compared traverse, for the report.

use speleo_simulator::{rmse_at_equal_times, PREDICTION_POINTS};

use super::{Exploration, HISTORY};
use crate::input::NavInput;

/// The executed track of a validated plan, sampled like the prediction.
pub(crate) struct Comparison {
    pub(crate) query: u64,
    pub(crate) predicted: Vec<[f64; 3]>,
    pub(crate) executed: Vec<[f64; 3]>,
    /// Motion began at this time; the next sample is due then.
    pub(crate) moving_since: Option<u64>,
    pub(crate) next_sample_ns: u64,
    pub(crate) active: bool,
}

impl Comparison {
    /// Follow plan `query` against the prediction now held.
    pub(crate) fn begin(&mut self, query: u64) {
        self.query = query;
        self.executed.clear();
        self.moving_since = None;
        self.active = true;
    }
}

impl Exploration {
    /// Plan `query`, validated, is handed over: its real track will be
    /// compared with the prediction.
    pub fn compare_next(&mut self, query: u64) {
        let Some(sim) = &self.sim else { return };
        let c = &mut self.comparison;
        c.predicted.clear();
        c.predicted.extend_from_slice(sim.prediction());
        c.begin(query);
    }

    /// The partial plan is handed over as plan `query`: compared with the
    /// prediction up to its end.
    pub fn compare_partial(&mut self, query: u64) {
        let c = &mut self.comparison;
        c.predicted.clear();
        c.predicted.extend_from_slice(&self.partial.predicted);
        c.begin(query);
    }

    /// Sample the real track of the plan being compared; at its end, the
    /// RMSE against the prediction.
    pub(crate) fn follow_comparison(&mut self, input: &NavInput) {
        let now = input.now_ns;
        let c = &mut self.comparison;
        if !c.active {
            return;
        }
        let (Some(cmd), Some(pose)) = (input.command, input.slam) else {
            return;
        };
        let cmd = cmd.value;
        if cmd.plan != c.query {
            return;
        }
        if c.moving_since.is_none() && (cmd.speed.abs() > 1e-3 || cmd.yaw_rate.abs() > 1e-3) {
            c.moving_since = Some(now);
            c.next_sample_ns = now;
        }
        if c.moving_since.is_some() && now >= c.next_sample_ns {
            if c.executed.len() < PREDICTION_POINTS {
                c.executed.push(pose.value.position);
            }
            c.next_sample_ns += 100_000_000;
        }
        if cmd.done {
            c.active = false;
            if let Some(e) = rmse_at_equal_times(&c.predicted, &c.executed) {
                tracing::debug!(
                    rmse_m = e,
                    predicted_s = c.predicted.len() as f64 * 0.1,
                    executed_s = c.executed.len() as f64 * 0.1,
                    "prediction compared"
                );
                if self.prediction_rmse_m.len() < HISTORY {
                    self.prediction_rmse_m.push(e);
                }
            }
        }
    }
}
