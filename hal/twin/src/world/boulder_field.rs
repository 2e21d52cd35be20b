//! A cluttered field: a 16 x 10 m floor strewn with boulders 0.3 to 1 m
//! across, like the paper's cluttered planning test. The start and the goal
//! sit 12 m apart on the long axis, each with a clear disc around it; the
//! straight line between them is blocked, so a path must weave.

use super::noise::uniform;
use super::shapes::{add_box, add_rock};
use speleo_physics::terrain::{Material, Mesh};

pub const SIZE_X: f64 = 16.0;
pub const SIZE_Y: f64 = 10.0;
/// The start and the goal: x, y, floor z, yaw.
pub const START: [f64; 4] = [2.0, 5.0, 0.0, 0.0];
pub const GOAL: [f64; 4] = [14.0, 5.0, 0.0, 0.0];
/// Boulders placed (fewer land: none within `CLEAR_M` of the start or the
/// goal, none overlapping another).
const BOULDERS: u64 = 90;
const CLEAR_M: f64 = 1.2;

pub struct BoulderField {
    pub mesh: Mesh,
    pub floor_area_m2: f64,
    /// x, y and size across of each boulder.
    pub boulders: Vec<[f64; 3]>,
}

pub fn generate(seed: u64) -> BoulderField {
    let mut mesh = Mesh::default();
    add_box(
        &mut mesh,
        [-1.0, -1.0, -0.5],
        [(SIZE_X + 1.0) as f32, (SIZE_Y + 1.0) as f32, 0.0],
        Material::Rock,
    );
    let mut boulders: Vec<[f64; 3]> = Vec::new();
    let mut covered = 0.0;
    for b in 0..BOULDERS {
        let x = 0.5 + uniform(seed ^ 0xB1, b as i64) * (SIZE_X - 1.0);
        let y = 0.5 + uniform(seed ^ 0xB2, b as i64) * (SIZE_Y - 1.0);
        let size = 0.3 + 0.7 * uniform(seed ^ 0xB3, b as i64);
        let near = |p: [f64; 4]| (x - p[0]).hypot(y - p[1]) < CLEAR_M + size / 2.0;
        let overlaps = boulders
            .iter()
            .any(|o| (x - o[0]).hypot(y - o[1]) < 0.6 * (size + o[2]));
        if near(START) || near(GOAL) || overlaps {
            continue;
        }
        add_rock(&mut mesh, x, y, 0.0, size, seed ^ b.wrapping_mul(0x9E37));
        covered += std::f64::consts::FRAC_PI_4 * size * size;
        boulders.push([x, y, size]);
    }
    BoulderField {
        mesh,
        floor_area_m2: (SIZE_X + 2.0) * (SIZE_Y + 2.0) - covered,
        boulders,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_field_is_cluttered_between_clear_ends_and_the_same_per_seed() {
        let f = generate(1);
        assert!(f.boulders.len() >= 40, "{} boulders", f.boulders.len());
        // The straight line from the start to the goal meets a boulder.
        let blocked = f
            .boulders
            .iter()
            .any(|b| (b[1] - START[1]).abs() < b[2] / 2.0 + 0.35);
        assert!(blocked);
        for b in &f.boulders {
            assert!((b[0] - START[0]).hypot(b[1] - START[1]) >= CLEAR_M);
            assert!((b[0] - GOAL[0]).hypot(b[1] - GOAL[1]) >= CLEAR_M);
        }
        assert_eq!(generate(1).mesh.triangles, f.mesh.triangles);
        assert_ne!(generate(2).boulders, f.boulders);
    }
}
