//! How a rover put down at a place stands there: on the ground under its
//! four wheels, pitched and rolled as that ground slopes, rather than level
//! with its uphill wheels in the slope.

use speleo_physics::terrain::Mesh;

/// How far above and below the given ground height a face may lie to count
/// as the ground there, m (a floor 3 m over or under is another level).
const SEARCH_UP_M: f64 = 0.5;
const SEARCH_DOWN_M: f64 = 1.0;

/// The height of the ground under (x, y) nearest above `z - SEARCH_DOWN_M`
/// and below `z + SEARCH_UP_M`: the highest upward face there.
pub fn ground_height(mesh: &Mesh, x: f64, y: f64, z: f64) -> Option<f64> {
    let mut best: Option<f64> = None;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let (_, n) = mesh.triangle_geometry(t);
        if n[2] <= 0.2 {
            continue;
        }
        let v = tri.map(|i| mesh.vertices[i as usize].map(f64::from));
        let d =
            (v[1][1] - v[2][1]) * (v[0][0] - v[2][0]) + (v[2][0] - v[1][0]) * (v[0][1] - v[2][1]);
        if d.abs() < 1e-12 {
            continue;
        }
        let a = ((v[1][1] - v[2][1]) * (x - v[2][0]) + (v[2][0] - v[1][0]) * (y - v[2][1])) / d;
        let b = ((v[2][1] - v[0][1]) * (x - v[2][0]) + (v[0][0] - v[2][0]) * (y - v[2][1])) / d;
        let c = 1.0 - a - b;
        if a < -1e-9 || b < -1e-9 || c < -1e-9 {
            continue;
        }
        let h = a * v[0][2] + b * v[1][2] + c * v[2][2];
        if h <= z + SEARCH_UP_M && h >= z - SEARCH_DOWN_M && best.is_none_or(|b| h > b) {
            best = Some(h);
        }
    }
    best
}

/// Where a rover of `wheelbase` by `track` (m) put down at `start` (x, y,
/// ground z, yaw) stands: the start with z the ground's height under its
/// centre (the mean of the four wheels'), and the (pitch, roll) of the
/// plane through them (rad, the Z-Y-X convention of `quat::from_ypr`). The
/// rover is lifted `lift` m (its wheels' radius and a gap) straight up from
/// the start's z; on a slope the start's z is raised so that the lift
/// across the slope is still `lift`. The start as given, level, where a
/// wheel has no ground under it.
pub fn standing(
    mesh: &Mesh,
    start: [f64; 4],
    wheelbase: f64,
    track: f64,
    lift: f64,
) -> ([f64; 4], [f64; 2]) {
    let [x, y, z, yaw] = start;
    let (s, c) = (libm::sin(yaw), libm::cos(yaw));
    let at = |fwd: f64, left: f64| {
        let (px, py) = (x + c * fwd - s * left, y + s * fwd + c * left);
        ground_height(mesh, px, py, z)
    };
    let (hw, ht) = (0.5 * wheelbase, 0.5 * track);
    let (Some(fl), Some(fr), Some(rl), Some(rr)) =
        (at(hw, ht), at(hw, -ht), at(-hw, ht), at(-hw, -ht))
    else {
        return (start, [0.0; 2]);
    };
    // Front higher than rear: nose up, a negative pitch; left higher than
    // right: a positive roll.
    let pitch = -libm::atan2((fl + fr - rl - rr) / 2.0, wheelbase);
    let roll = libm::atan2((fl + rl - fr - rr) / 2.0, track);
    // The body's up axis leans by the tilt: straight up, the wheels would
    // stand `lift` cos(tilt) off a steep slope, inside it past ~18 deg.
    let cos_tilt = (libm::cos(pitch) * libm::cos(roll)).max(0.2);
    let z = (fl + fr + rl + rr) / 4.0 + lift * (1.0 / cos_tilt - 1.0);
    ([x, y, z, yaw], [pitch, roll])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{shapes, Material};

    /// A ramp rising `rise` m over 10 m along x, from x = 0.
    fn ramp(rise: f32) -> Mesh {
        let mut m = Mesh::default();
        m.push_triangle(
            [0.0, -5.0, 0.0],
            [10.0, -5.0, rise],
            [10.0, 5.0, rise],
            Material::Rock,
        );
        m.push_triangle(
            [0.0, -5.0, 0.0],
            [10.0, 5.0, rise],
            [0.0, 5.0, 0.0],
            Material::Rock,
        );
        m
    }

    #[test]
    fn a_rover_put_down_on_a_slope_stands_along_it() {
        let m = ramp(1.0);
        let slope = (0.1f64).atan();
        // Facing up the slope: nose up.
        let (p, [pitch, roll]) = standing(&m, [5.0, 0.0, 0.5, 0.0], 0.52, 0.52, 0.2);
        assert!((pitch + slope).abs() < 1e-6, "{pitch}");
        assert!(roll.abs() < 1e-6);
        // Raised so that its wheels clear the slope by the lift across it.
        assert!(
            (p[2] - (0.5 + 0.2 * (1.0 / slope.cos() - 1.0))).abs() < 1e-9,
            "{p:?}"
        );
        // Facing across it (along -y), the slope rising on its left: rolled
        // left side up.
        let (_, [pitch, roll]) = standing(
            &m,
            [5.0, 0.0, 0.5, -std::f64::consts::FRAC_PI_2],
            0.52,
            0.52,
            0.2,
        );
        assert!(pitch.abs() < 1e-6, "{pitch}");
        assert!((roll - slope).abs() < 1e-6, "{roll}");
    }

    #[test]
    fn the_ground_is_the_level_the_rover_is_on_not_the_one_above() {
        let mut m = Mesh::default();
        shapes::add_box(
            &mut m,
            [-5.0, -5.0, -0.2],
            [5.0, 5.0, 0.0],
            Material::Concrete,
        );
        shapes::add_box(
            &mut m,
            [-5.0, -5.0, 2.8],
            [5.0, 5.0, 3.0],
            Material::Concrete,
        );
        assert_eq!(ground_height(&m, 1.0, 1.0, 0.0), Some(0.0));
        assert_eq!(ground_height(&m, 1.0, 1.0, 3.0), Some(3.0));
        // Off the slab: nothing, and the start stays as given, level.
        assert_eq!(ground_height(&m, 9.0, 1.0, 0.0), None);
        let (p, tilt) = standing(&m, [4.9, 0.0, 0.0, 0.0], 0.52, 0.52, 0.2);
        assert_eq!((p, tilt), ([4.9, 0.0, 0.0, 0.0], [0.0; 2]));
    }
}
