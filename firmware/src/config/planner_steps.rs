//! `[planner.step_units]`: the work units one planner step does in each of
//! its phases. A unit is about an ARA* expansion's work, but the phases'
//! units differ in their tails (the internal simulator's physics steps
//! vary with the contacts, the search's expansions with the checked
//! bodies), so each phase gets as many as fill 90 % of the task's window
//! at its own p99.9. `speleo wcet --calibrate` writes this table from a run's
//! step times; the defaults are that output on the development machine.

use serde::{Deserialize, Serialize};

use super::{range, ConfigError};

pub use speleo_navigator::STEP_PHASES;

/// Most units a step of any phase may do.
pub const MAX_STEP_UNITS: u32 = 1024;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlannerStepUnits {
    /// Units growing the traversability graph (800 of its work each: cells
    /// and patches read, points a plane fit tests; about two nodes).
    pub grow: u32,
    /// Units scanning nodes for the start and the goal (128 nodes each).
    pub pick: u32,
    /// Units scanning for exploration candidates (128 nodes looked at or
    /// cells looked up each).
    pub candidates: u32,
    /// Units preparing the lattice (cells copied, rooms checked, cost-to-go
    /// pops).
    pub prepare: u32,
    /// ARA* work (1,024 lattice steps and footprint cells each, about an
    /// expansion on open ground).
    pub search: u32,
    /// Internal simulator units (256 points integrated, a tile meshed, a
    /// sixth of a physics step).
    pub validate: u32,
}

impl Default for PlannerStepUnits {
    /// `speleo wcet --calibrate` on the idle development machine (2 cores,
    /// the six default scenarios) for the 1 ms window the planner had then;
    /// beside another mission they fill the 1.5 ms window it has now
    /// (`docs/mission-history.md` has both measurements). Pick made too
    /// few steps to measure (a scan of 128 nodes a unit, ~1 us).
    fn default() -> Self {
        PlannerStepUnits {
            grow: 54,
            pick: 128,
            candidates: 35,
            prepare: 19,
            search: 18,
            validate: 14,
        }
    }
}

impl PlannerStepUnits {
    /// The units in [`STEP_PHASES`] order.
    pub fn as_array(&self) -> [u32; 6] {
        [
            self.grow,
            self.pick,
            self.candidates,
            self.prepare,
            self.search,
            self.validate,
        ]
    }

    /// The table from units in [`STEP_PHASES`] order.
    pub fn from_array(u: [u32; 6]) -> Self {
        PlannerStepUnits {
            grow: u[0],
            pick: u[1],
            candidates: u[2],
            prepare: u[3],
            search: u[4],
            validate: u[5],
        }
    }

    pub(super) fn validate(&self) -> Result<(), ConfigError> {
        for (name, v) in STEP_PHASES.iter().zip(self.as_array()) {
            range(
                &format!("planner.step_units.{name}"),
                v,
                1,
                MAX_STEP_UNITS,
                "1..=1024",
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_array_order_is_the_field_order() {
        let u = PlannerStepUnits::from_array([1, 2, 3, 4, 5, 6]);
        assert_eq!(u.grow, 1);
        assert_eq!(u.validate, 6);
        assert_eq!(u.as_array(), [1, 2, 3, 4, 5, 6]);
    }

    #[test]
    fn zero_units_are_refused_with_the_key() {
        let u = PlannerStepUnits {
            search: 0,
            ..Default::default()
        };
        let e = u.validate().expect_err("0 units").to_string();
        assert!(e.contains("planner.step_units.search"), "{e}");
    }
}
