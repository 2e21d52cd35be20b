//! What the traversability map knows of the robot. Only the keys
//! `[planner]` has always had are read and written; the rest keep their
//! defaults.

use speleo_params::{decimal, range, ParamError};

/// Limits and robot dimensions (m, degrees).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(default, deny_unknown_fields)
)]
pub struct TravParams {
    /// Steepest support plane the robot drives.
    pub max_slope_deg: f64,
    /// Highest step the robot climbs: between neighbouring patches (for
    /// them to connect) and between the support plane and any ground
    /// patch under the footprint.
    pub max_step_m: f32,
    /// Unobserved gaps in the ground up to this wide are bridged where
    /// ground continues beyond them (0: never).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub max_gap_m: f64,
    /// Radius of the ground that carries the robot (the support plane is
    /// fitted over it).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub footprint_radius_m: f64,
    /// Radius, from the node, of the ring of cells where a deep drop
    /// blocks the node (no ring when within the footprint; 0, off, by
    /// default). The footprint's own drop check lets the wheels run a few
    /// centimetres from an open edge: the garage rover that a plan sent
    /// along a ramp's side slid off it. At 0.7 m (drops of 0.5 m or 1 m)
    /// that rover came home instead, but the lava tube's mission took
    /// another course and was stranded behind its start (coverage 0.31).
    pub drop_clearance_m: f64,
    /// A drop at least this deep is deep for `drop_clearance_m`: one the
    /// rover cannot drive out of, not a ledge of the cave's floor.
    pub deep_drop_m: f32,
    /// Radius the body covers in every orientation (half its width): the
    /// orientation-free obstacle check looks only there.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub inscribed_radius_m: f64,
    /// The body spans from this height above the plane...
    pub ground_clearance_m: f32,
    /// ...to this one.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub robot_height_m: f32,
    /// Fewer plane inliers make a patch unknown (the paper: 5).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub min_inliers: usize,
    /// Distance from the plane that makes a point an inlier.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub inlier_distance_m: f32,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub ransac_iterations: usize,
    /// Most patches the map holds.
    pub max_nodes: usize,
    /// Cells of the largest growth window: their nodes are indexed on a
    /// dense grid (4 bytes a cell, taken at construction), which keeps
    /// growth's lookups in the caches. Larger windows, and growth without
    /// one, hash their cells.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub max_window_cells: usize,
}

impl Default for TravParams {
    /// The simulated Asguard-like rover: 0.52 m wheelbase and track, 0.19 m
    /// leg-wheels (about 0.9 x 0.7 m), the chassis' underside 0.12 m over
    /// the ground on its hubs (0.08 m when two legs stand), the LiDAR on top
    /// at 0.6 m. The body band starts at the underside, 0.12 m: rocks of
    /// 0.14 to 0.22 m under the chassis stranded the exploring rover in the
    /// simulated lava tube (at m80 and m100), and steps up to 0.1 m are
    /// climbed (the leg-wheels climb 0.2 m, the belly must clear them).
    fn default() -> Self {
        TravParams {
            max_slope_deg: 25.0,
            max_step_m: 0.10,
            max_gap_m: 0.6,
            footprint_radius_m: 0.4,
            drop_clearance_m: 0.0,
            deep_drop_m: 0.5,
            inscribed_radius_m: 0.3,
            ground_clearance_m: 0.12,
            robot_height_m: 0.7,
            min_inliers: 5,
            inlier_distance_m: 0.04,
            ransac_iterations: 24,
            max_nodes: 1 << 20,
            max_window_cells: 0,
        }
    }
}

impl TravParams {
    /// The first configurable limit out of the range the rover accepts, by
    /// its key (stricter than [`TravParams::check`]).
    pub fn validate(&self) -> Result<(), ParamError> {
        range("max_nodes", self.max_nodes, 16, 1 << 22, "16..=4194304")?;
        range("max_slope_deg", self.max_slope_deg, 1.0, 80.0, "1..=80")?;
        // Under the body's top (`robot_height_m`, 0.7 m).
        let clearance = decimal(self.ground_clearance_m);
        range("ground_clearance_m", clearance, 0.02, 0.69, "0.02..=0.69")?;
        // The bound is a difference of decimals: a micrometre of slack.
        range(
            "max_step_m",
            decimal(self.max_step_m),
            0.01,
            clearance - 0.01 + 1e-6,
            "0.01..=ground_clearance_m - 0.01",
        )?;
        range("drop_clearance_m", self.drop_clearance_m, 0.0, 5.0, "0..=5")?;
        range(
            "deep_drop_m",
            decimal(self.deep_drop_m),
            0.01,
            100.0,
            "0.01..=100",
        )
    }

    /// Why these parameters cannot work, if they cannot.
    pub fn check(&self) -> Result<(), String> {
        let positive = [
            ("max_slope_deg", self.max_slope_deg),
            ("max_step_m", self.max_step_m as f64),
            ("footprint_radius_m", self.footprint_radius_m),
            ("inscribed_radius_m", self.inscribed_radius_m),
            ("robot_height_m", self.robot_height_m as f64),
            ("inlier_distance_m", self.inlier_distance_m as f64),
        ];
        for (k, v) in positive {
            if !(v > 0.0 && v.is_finite()) {
                return Err(format!("{k} must be a positive number"));
            }
        }
        if !(self.ground_clearance_m > self.max_step_m
            && self.ground_clearance_m < self.robot_height_m)
        {
            return Err("ground_clearance_m must lie between max_step_m and robot_height_m".into());
        }
        if !(self.drop_clearance_m >= 0.0 && self.drop_clearance_m <= 5.0) {
            return Err("drop_clearance_m must lie in 0..=5".into());
        }
        if !(self.deep_drop_m > 0.0 && self.deep_drop_m.is_finite()) {
            return Err("deep_drop_m must be a positive number".into());
        }
        if !(self.max_gap_m >= 0.0 && self.max_gap_m <= 10.0) {
            return Err("max_gap_m must lie in 0..=10".into());
        }
        if self.max_slope_deg >= 90.0 || self.min_inliers < 3 || self.ransac_iterations == 0 {
            return Err(
                "max_slope_deg below 90, min_inliers at least 3, ransac_iterations at least 1"
                    .into(),
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_limits_validate_as_the_decimals_written() {
        TravParams::default()
            .validate()
            .expect("the rover's limits");
        // 0.1 as f32 is a hair over 0.11 - 0.01: the decimals compare.
        let p = TravParams {
            ground_clearance_m: 0.11,
            ..TravParams::default()
        };
        p.validate().expect("a step 0.01 under the clearance");
        let p = TravParams {
            ground_clearance_m: 0.105,
            ..TravParams::default()
        };
        let e = p.validate().expect_err("the step reaches the clearance");
        assert_eq!(e.key(), "max_step_m", "{e}");
        let p = TravParams {
            ground_clearance_m: 0.02,
            max_step_m: 0.01,
            ..TravParams::default()
        };
        p.validate().expect("the lowest clearance as written");
        let p = TravParams {
            max_slope_deg: 85.0,
            ..TravParams::default()
        };
        assert_eq!(p.validate().expect_err("too steep").key(), "max_slope_deg");
    }
}
