//! The ranges the rover accepts the navigator's settings in, the graph's
//! and the lattice's with them.

use speleo_params::{decimal, range, ParamError};

use super::NavigatorParams;

impl NavigatorParams {
    /// The first configurable setting out of the range the rover accepts,
    /// by its key (the keys of `[planner]`).
    pub fn validate(&self) -> Result<(), ParamError> {
        range("window_m", self.window_m, 2.0, 500.0, "2..=500")?;
        range(
            "window_max_m",
            self.window_max_m,
            self.window_m,
            500.0,
            "window_m..=500",
        )?;
        range(
            "goal_ahead_m",
            self.goal_ahead_m,
            0.5,
            self.window_m / 2.0,
            "0.5..=window_m / 2",
        )?;
        range(
            "replan_every_s",
            self.replan_every_s,
            0.1,
            3600.0,
            "0.1..=3600",
        )?;
        range(
            "max_expansions",
            self.max_expansions,
            1,
            u32::MAX as u64,
            "1..=4294967295",
        )?;
        range("initial_eps", self.initial_eps, 1.0, 100.0, "1..=100")?;
        range("eps_step", self.eps_step, 0.001, 100.0, "0.001..=100")?;
        self.trav.validate()?;
        self.surface.validate()?;
        // Over the ground clearance the body band refuses the node anyway.
        range(
            "max_bump_m",
            self.surface.max_bump_m,
            0.0,
            decimal(self.trav.ground_clearance_m),
            "0..=ground_clearance_m",
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_are_valid_and_a_bump_over_the_clearance_is_named() {
        NavigatorParams::default().validate().expect("the rover's");
        let mut p = NavigatorParams::default();
        p.surface.max_bump_m = 0.13;
        let e = p.validate().expect_err("over the clearance");
        assert_eq!(e.key(), "max_bump_m", "{e}");
        p.surface.max_bump_m = 0.12;
        p.validate().expect("at the clearance as written");
        let p = NavigatorParams {
            goal_ahead_m: 20.0,
            ..NavigatorParams::default()
        };
        assert_eq!(p.validate().expect_err("past").key(), "goal_ahead_m");
    }
}
