//! SLAM's settings (`[slam]`) and the ranges the rover accepts them in.
//! Only the keys `[slam]` has always had are read and written; the rest
//! keep their defaults.

use speleo_params::{positive, range, ParamError};

use crate::registration::gicp::GicpParams;

/// Settings, from the `[slam]` configuration table.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(default, deny_unknown_fields)
)]
pub struct SlamParams {
    /// Keyframes the store holds; when full, no more are added (reported).
    pub keyframe_capacity: usize,
    /// Keyframes kept free in the optimisation, each a state of its own;
    /// older ones join rigid sub-maps...
    pub active_keyframes: usize,
    /// ...of this many keyframes, which move as one: the system keeps one
    /// block per sub-map, so past the window its size grows this many times
    /// slower than the trajectory, and a loop closure can still bend the
    /// whole path
    /// (freezing the past could not: the return leg of an out-and-back
    /// would be pinned to the outbound leg's drift). 1 keeps every
    /// keyframe free.
    pub submap_keyframes: usize,
    pub keyframe_distance_m: f64,
    pub keyframe_angle_deg: f64,
    /// Voxel size of the registration clouds.
    pub voxel_m: f64,
    /// Returns farther than this from the sensor stay out of keyframes
    /// (`offer_scan` takes base-frame points, so the caller drops them).
    /// Far returns are sparse rings that move with the sensor: in the
    /// simulated tube, scans 1 m apart registered with every return read
    /// the motion 0.3% short with 10 mm RMS along the tube; within 10 m,
    /// 0.08% and 5 mm (tests/tube_registration.rs).
    pub max_range_m: f64,
    /// Points kept per keyframe scan after downsampling.
    pub max_scan_points: usize,
    /// GICP factors to this many nearest recent keyframes (the previous
    /// one included).
    pub neighbors: usize,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub neighbor_radius_m: f64,
    /// Loop candidates: keyframes at least `loop_min_gap` keyframes older
    /// within this distance of the new one.
    pub loop_radius_m: f64,
    pub loop_min_gap: usize,
    /// Every registration is refined by a second alignment that pairs
    /// points only within this distance (the first one's reach is
    /// `gicp.max_correspondence_m`, needed to converge from odometry). The
    /// wide reach alone biases the motion short: where the new scan sees
    /// beyond the old one's coverage, its points pair with the old scan's
    /// last ones, up to a keyframe spacing back.
    pub refine_distance_m: f64,
    /// ...keeping only mutual nearest neighbours (`GicpParams::mutual`).
    pub refine_mutual: bool,
    /// A registration's directions where the surfaces' normals carry less
    /// than this share of the information keep the guess and weigh
    /// nothing in the graph (`registration::degeneracy`); 0: off, the
    /// default. On a garage's bare roof the scans read the motion as none
    /// (shares 0.23 at most, the lava tube's axis 0.60 at least); turned
    /// on, it changed the missions' paths, see the README.
    pub min_surface_share: f64,
    /// Loops are refined within this distance, and verified on it...
    pub loop_verify_distance_m: f64,
    /// ...and accepted when its inlier RMSE is below this...
    pub loop_max_fitness_m: f64,
    /// ...and this share of the source points found a correspondence.
    pub loop_min_inlier_fraction: f64,
    /// Odometry noise: standard deviation per metre driven. Loose: the
    /// leg-wheels over-read by a few percent (their rolling radius changes
    /// with load and ground), and a tighter odometry pulls the GICP chain
    /// long by that bias wherever the tube constrains the axis weakly.
    pub odom_sigma_m_per_m: f64,
    /// ...along the previous keyframe's z axis: the height gained comes
    /// from the IMU's gravity-referenced pitch, which slip barely touches.
    pub odom_sigma_vertical_m_per_m: f64,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub odom_sigma_rad_per_m: f64,
    /// Heading drift of the odometry per second (the gyro's uncompensated
    /// bias): a rover that turns in place or sits for a minute between
    /// keyframes has travelled little but its heading has drifted.
    pub odom_sigma_rad_per_s: f64,
    pub inclination_sigma_deg: f64,
    /// GICP's Hessian assumes independent points; scale it to an honest
    /// information.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub gicp_information_scale: f64,
    /// Cauchy kernel scale (whitened units) of the GICP factors.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub robust_scale: f64,
    /// LM iterations after each new keyframe.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub iterations_per_keyframe: u32,
    /// Points one step of cloud work visits (downsampling, covariances, a
    /// part of a GICP pass): bounds the time of a step.
    pub points_per_step: usize,
    /// Factors one step of Levenberg-Marquardt linearises or costs: with
    /// the factorisation in a step of its own, this bounds the time of an
    /// optimisation step however large the active graph grows.
    pub factors_per_step: usize,
    /// Estimate the IMU-to-LiDAR bias (else it is held at the identity).
    pub estimate_bias: bool,
    /// Standard deviation of the bias prior (mounting tolerance), deg.
    pub bias_prior_deg: f64,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub gicp: GicpParams,
}

impl Default for SlamParams {
    fn default() -> Self {
        SlamParams {
            keyframe_capacity: 2048,
            active_keyframes: 100,
            submap_keyframes: 5,
            keyframe_distance_m: 1.0,
            keyframe_angle_deg: 15.0,
            voxel_m: 0.2,
            max_range_m: 10.0,
            max_scan_points: 12_000,
            neighbors: 3,
            neighbor_radius_m: 8.0,
            loop_radius_m: 5.0,
            loop_min_gap: 25,
            refine_distance_m: 0.25,
            refine_mutual: true,
            min_surface_share: 0.0,
            loop_verify_distance_m: 0.4,
            loop_max_fitness_m: 0.18,
            loop_min_inlier_fraction: 0.4,
            odom_sigma_m_per_m: 0.2,
            odom_sigma_vertical_m_per_m: 0.05,
            odom_sigma_rad_per_m: 0.02,
            odom_sigma_rad_per_s: 1e-3,
            inclination_sigma_deg: 1.0,
            gicp_information_scale: 0.05,
            robust_scale: 3.0,
            iterations_per_keyframe: 6,
            points_per_step: 1200,
            factors_per_step: 1000,
            estimate_bias: true,
            bias_prior_deg: 1.0,
            gicp: GicpParams {
                max_correspondence_m: 1.0,
                max_iterations: 30,
                ..GicpParams::default()
            },
        }
    }
}

impl SlamParams {
    /// The first setting out of the range the rover accepts, by its key.
    pub fn validate(&self) -> Result<(), ParamError> {
        range(
            "keyframe_capacity",
            self.keyframe_capacity,
            2,
            100_000,
            "2..=100000",
        )?;
        range(
            "active_keyframes",
            self.active_keyframes,
            2,
            100_000,
            "2..=100000",
        )?;
        range(
            "max_scan_points",
            self.max_scan_points,
            100,
            1_000_000,
            "100..=1000000",
        )?;
        range(
            "submap_keyframes",
            self.submap_keyframes,
            1,
            1000,
            "1..=1000",
        )?;
        range(
            "factors_per_step",
            self.factors_per_step,
            10,
            1_000_000,
            "10..=1000000",
        )?;
        range("neighbors", self.neighbors, 1, 6, "1..=6")?;
        range(
            "loop_min_inlier_fraction",
            self.loop_min_inlier_fraction,
            0.0,
            1.0,
            "0..=1",
        )?;
        range(
            "points_per_step",
            self.points_per_step,
            100,
            1_000_000,
            "100..=1000000",
        )?;
        for (key, v) in [
            ("keyframe_distance_m", self.keyframe_distance_m),
            ("keyframe_angle_deg", self.keyframe_angle_deg),
            ("voxel_m", self.voxel_m),
            ("max_range_m", self.max_range_m),
            ("loop_radius_m", self.loop_radius_m),
            ("refine_distance_m", self.refine_distance_m),
            ("loop_verify_distance_m", self.loop_verify_distance_m),
            ("loop_max_fitness_m", self.loop_max_fitness_m),
            ("loop_min_inlier_fraction", self.loop_min_inlier_fraction),
            ("odom_sigma_m_per_m", self.odom_sigma_m_per_m),
            ("odom_sigma_rad_per_s", self.odom_sigma_rad_per_s),
            (
                "odom_sigma_vertical_m_per_m",
                self.odom_sigma_vertical_m_per_m,
            ),
            ("inclination_sigma_deg", self.inclination_sigma_deg),
            ("bias_prior_deg", self.bias_prior_deg),
        ] {
            positive(key, v)?;
        }
        let m = self.min_surface_share;
        if !(0.0..=1.0).contains(&m) {
            return Err(ParamError::Invalid {
                key: "min_surface_share".into(),
                why: format!("{m} is not a share from 0 to 1"),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_are_valid_and_a_value_out_of_range_is_named() {
        SlamParams::default()
            .validate()
            .expect("the rover's settings");
        let p = SlamParams {
            neighbors: 7,
            ..SlamParams::default()
        };
        let e = p.validate().expect_err("7 neighbours");
        assert_eq!(e.key(), "neighbors");
        for share in [1.5, -0.1, f64::NAN] {
            let p = SlamParams {
                min_surface_share: share,
                ..SlamParams::default()
            };
            let e = p.validate().expect_err("not a share");
            assert_eq!(e.key(), "min_surface_share", "{e}");
        }
        let p = SlamParams {
            voxel_m: 0.0,
            ..SlamParams::default()
        };
        assert_eq!(p.validate().expect_err("zero voxels").key(), "voxel_m");
    }
}
