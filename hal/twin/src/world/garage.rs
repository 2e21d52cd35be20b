//! A multi-level parking garage, like the simulated one the paper uses to
//! test multi-level planning: three 22 x 20 m levels (about 1,320 m2 of
//! floor), 3 m apart, joined by 4 m wide ramps through openings in the slabs,
//! with pillars and perimeter walls.

use super::shapes::{add_box, add_hexahedron};
use speleo_physics::terrain::{Material, Mesh};

pub const LEVELS: usize = 3;
pub const SIZE_X: f32 = 22.0;
pub const SIZE_Y: f32 = 20.0;
pub const LEVEL_HEIGHT: f32 = 3.0;
const SLAB: f32 = 0.25;
const WALL: f32 = 0.3;
const RAMP_WIDTH: f32 = 4.0;
const RAMP_LENGTH: f32 = 12.0;

pub struct Garage {
    pub mesh: Mesh,
    pub floor_area_m2: f64,
    pub start: [f64; 4],
    /// From the start up both ramps to the top level (for scripted drives).
    pub route: Vec<[f64; 3]>,
}

/// The ramp from level `l` to `l + 1` runs along +x on alternate sides.
fn ramp_y(l: usize) -> (f32, f32) {
    if l.is_multiple_of(2) {
        (SIZE_Y - WALL - RAMP_WIDTH, SIZE_Y - WALL)
    } else {
        (WALL, WALL + RAMP_WIDTH)
    }
}
const RAMP_X0: f32 = 5.0;

pub fn generate() -> Garage {
    let mut m = Mesh::default();
    let mut floor = 0.0f64;
    for l in 0..=LEVELS {
        let z = l as f32 * LEVEL_HEIGHT;
        // The slab of level l, with the opening of the ramp arriving from below.
        let top = z;
        let lo = z - SLAB;
        if l > 0 {
            let (y0, y1) = ramp_y(l - 1);
            let (x0, x1) = (RAMP_X0, RAMP_X0 + RAMP_LENGTH);
            add_box(
                &mut m,
                [0.0, 0.0, lo],
                [x0, SIZE_Y, top],
                Material::Concrete,
            );
            add_box(
                &mut m,
                [x1, 0.0, lo],
                [SIZE_X, SIZE_Y, top],
                Material::Concrete,
            );
            add_box(&mut m, [x0, 0.0, lo], [x1, y0, top], Material::Concrete);
            add_box(&mut m, [x0, y1, lo], [x1, SIZE_Y, top], Material::Concrete);
        } else {
            add_box(
                &mut m,
                [-5.0, -5.0, lo],
                [SIZE_X + 5.0, SIZE_Y + 5.0, top],
                Material::Concrete,
            );
        }
        if l == LEVELS {
            break; // the roof
        }
        let usable = SIZE_X * SIZE_Y - if l > 0 { RAMP_LENGTH * RAMP_WIDTH } else { 0.0 };
        floor += usable as f64;
        // Perimeter walls up to the next slab.
        let h = z + LEVEL_HEIGHT - SLAB;
        add_box(&mut m, [0.0, 0.0, z], [SIZE_X, WALL, h], Material::Concrete);
        add_box(
            &mut m,
            [0.0, SIZE_Y - WALL, z],
            [SIZE_X, SIZE_Y, h],
            Material::Concrete,
        );
        add_box(&mut m, [0.0, 0.0, z], [WALL, SIZE_Y, h], Material::Concrete);
        add_box(
            &mut m,
            [SIZE_X - WALL, 0.0, z],
            [SIZE_X, SIZE_Y, h],
            Material::Concrete,
        );
        // Pillars every 7 m, clear of the ramps.
        for px in [7.0f32, 14.0] {
            for py in [7.0f32, 13.0] {
                add_box(
                    &mut m,
                    [px - 0.25, py - 0.25, z],
                    [px + 0.25, py + 0.25, h],
                    Material::Concrete,
                );
            }
        }
        // The ramp up to the next level: a sloped slab.
        let (y0, y1) = ramp_y(l);
        let (x0, x1) = (RAMP_X0, RAMP_X0 + RAMP_LENGTH);
        let (zb, zt) = (z, z + LEVEL_HEIGHT);
        add_hexahedron(
            &mut m,
            [
                [x0, y0, zb - SLAB],
                [x1, y0, zt - SLAB],
                [x1, y1, zt - SLAB],
                [x0, y1, zb - SLAB],
                [x0, y0, zb],
                [x1, y0, zt],
                [x1, y1, zt],
                [x0, y1, zb],
            ],
            Material::Concrete,
        );
        floor += (RAMP_WIDTH * (RAMP_LENGTH.hypot(LEVEL_HEIGHT))) as f64;
    }
    Garage {
        mesh: m,
        floor_area_m2: floor,
        start: [2.5, 0.5 * SIZE_Y as f64, 0.0, 0.0],
        route: route(),
    }
}

/// Along level 0 to the first ramp, up it, round the level-1 pillars to the
/// second ramp and up to level 2: clear of walls and pillars by 1 m or more.
fn route() -> Vec<[f64; 3]> {
    let h = LEVEL_HEIGHT as f64;
    let (r0, r1) = (ramp_y(0), ramp_y(1));
    let y0 = 0.5 * (r0.0 + r0.1) as f64;
    let y1 = 0.5 * (r1.0 + r1.1) as f64;
    let (xa, xb) = (RAMP_X0 as f64, (RAMP_X0 + RAMP_LENGTH) as f64);
    vec![
        [4.0, 10.0, 0.0],
        [3.5, y0 - 2.0, 0.0],
        [xa - 0.5, y0, 0.0],
        [xb, y0, h],
        [xb + 2.5, y0 - 1.5, h],
        [xb + 3.0, 10.0, h],
        [xb, 10.0, h],
        [3.5, 10.0, h],
        [2.5, y1 + 2.5, h],
        [xa - 0.5, y1, h],
        [xb, y1, 2.0 * h],
        [xb + 3.0, y1, 2.0 * h],
    ]
}
