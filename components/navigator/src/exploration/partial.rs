//! The longest well-driven first part of the plans the internal
//! simulation refused in one query.

use speleo_messages::PLAN_POSES;
use speleo_simulator::{driven_prefix, Prefix, PrefixRule, PREDICTION_POINTS};

use super::Exploration;

/// The longest well-driven first part of the plans the simulation refused
/// in one query ([`speleo_simulator::driven_prefix`]): the rover drives it
/// when no goal of the query passes. A garage ramp seen from the level
/// under it is ground up to the sensor's height and an underside beyond,
/// where the simulated rover stalls; from partway up, the rest is seen.
pub struct Partial {
    pub poses: heapless::Vec<[f32; 4], PLAN_POSES>,
    /// The prediction up to the last pose.
    pub predicted: Vec<[f64; 3]>,
    pub length_m: f64,
    /// The refused goal it was on the way to.
    pub goal: [f64; 3],
}

impl Partial {
    pub fn clear(&mut self) {
        self.poses.clear();
        self.predicted.clear();
        self.length_m = 0.0;
    }

    /// Keep `prefix` of `plan` (and of `prediction`) if it is longer than
    /// the one kept.
    pub fn offer(
        &mut self,
        plan: &[[f32; 4]],
        prediction: &[[f64; 3]],
        prefix: Prefix,
        goal: [f64; 3],
    ) {
        if prefix.length_m <= self.length_m {
            return;
        }
        self.clear();
        for q in &plan[..prefix.poses.min(plan.len())] {
            let _ = self.poses.push(*q);
        }
        let n = prefix.samples.min(prediction.len()).min(PREDICTION_POINTS);
        self.predicted.extend_from_slice(&prediction[..n]);
        self.length_m = prefix.length_m;
        self.goal = goal;
    }
}

impl Exploration {
    /// The simulation refused `plan` (to `goal`): keep its well-driven
    /// first part if it is the longest this query.
    pub fn offer_partial(&mut self, plan: &[[f32; 4]], goal: [f64; 3]) {
        let Some(sim) = self.sim.as_deref() else {
            return;
        };
        self.partial_scratch.clear();
        self.partial_scratch
            .extend(plan.iter().map(|p| p.map(f64::from)));
        let prediction = sim.prediction();
        if let Some(prefix) =
            driven_prefix(&self.partial_scratch, prediction, PrefixRule::default())
        {
            self.partial.offer(plan, prediction, prefix, goal);
        }
    }
}
