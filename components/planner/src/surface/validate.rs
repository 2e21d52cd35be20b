//! The ranges the rover accepts the surface lattice's settings in.

use speleo_params::{range, ParamError};

use super::SurfaceParams;

impl SurfaceParams {
    /// The first configurable setting out of the range the rover accepts,
    /// by its key.
    pub fn validate(&self) -> Result<(), ParamError> {
        for (k, v) in [
            ("forward_speed_mps", self.forward_speed_mps),
            ("backward_speed_mps", self.backward_speed_mps),
            ("turn_speed_rad_s", self.turn_speed_rad_s),
            ("body_length_m", self.body_length_m),
            ("body_width_m", self.body_width_m),
        ] {
            range(k, v, 0.01, 10.0, "0.01..=10")?;
        }
        for (k, v) in [
            ("clearance_weight", self.clearance_weight),
            ("bump_weight", self.bump_weight),
            ("edge_weight", self.edge_weight),
        ] {
            range(k, v, 0.0, 100.0, "0..=100")?;
        }
        range("body_drop_cells", self.body_drop_cells, 0, 1000, "0..=1000")?;
        // With the term on, each node's cell scan widens by this reach:
        // bounded, so a preparation unit's time is.
        // `max_bump_m` is bounded by the traversability map's ground
        // clearance, which the navigator holds with these.
        range("edge_reach_m", self.edge_reach_m, 0.1, 2.0, "0.1..=2")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_are_valid_and_a_value_out_of_range_is_named() {
        SurfaceParams::default().validate().expect("the rover's");
        let p = SurfaceParams {
            edge_reach_m: 3.0,
            ..SurfaceParams::default()
        };
        assert_eq!(p.validate().expect_err("too far").key(), "edge_reach_m");
        let p = SurfaceParams {
            forward_speed_mps: f64::NAN,
            ..SurfaceParams::default()
        };
        let e = p.validate().expect_err("not a number");
        assert_eq!(e.key(), "forward_speed_mps", "{e}");
    }
}
