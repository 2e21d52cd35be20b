//! The lattice's body check against parry3d: every primitive the lattice
//! accepts must leave the body's oriented box (0.9 x 0.7 m, from 0.2 to
//! 0.7 m over the ground) clear of every occupied interval of the map, at
//! every intermediate pose, tested as box against box by parry3d. The
//! lattice rasterises the box into cells, so the reference box is shrunk
//! by a few centimetres (the sampling of a cell's corner).

use parry3d::math::{Pose, Rotation, Vector};
use parry3d::shape::Cuboid;
use speleo_mapping::mls::{MlsMap, MlsParams};
use speleo_planner::arastar::Lattice;
use speleo_planner::primitives::{generate, PrimitiveSpec};
use speleo_planner::surface::{SurfaceLattice, SurfaceParams};
use speleo_traversability::{TravMap, TravParams};

/// Points every 5 cm over a rectangle at height `z`.
fn surface(m: &mut MlsMap, x: (f64, f64), y: (f64, f64), z: f64) {
    let mut pts = Vec::new();
    let mut px = x.0 + 0.025;
    while px < x.1 {
        let mut py = y.0 + 0.025;
        while py < y.1 {
            pts.push([px, py, z]);
            py += 0.05;
        }
        px += 0.05;
    }
    m.insert_points(&pts);
}

/// A 10 x 8 m floor with rocks of 0.2 to 0.5 m squared, 0.3 to 1 m tall,
/// and a 1.2 m wide shelf 0.5 m over the floor (the body fits under it in
/// no pose: it spans the band).
fn clutter(seed: u64) -> (MlsMap, Vec<[f64; 4]>) {
    let mut m = MlsMap::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
    surface(&mut m, (0.0, 10.0), (0.0, 8.0), 0.0);
    let mut s = seed;
    let mut rand = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s % 10_000) as f64 / 10_000.0
    };
    let mut rocks = Vec::new();
    for _ in 0..14 {
        let (x, y) = (1.5 + 7.0 * rand(), 1.0 + 6.0 * rand());
        let (half, top) = (0.1 + 0.15 * rand(), 0.3 + 0.7 * rand());
        let mut h = 0.05;
        while h <= top {
            surface(&mut m, (x - half, x + half), (y - half, y + half), h);
            h += 0.05;
        }
        rocks.push([x, y, half, top]);
    }
    surface(&mut m, (7.0, 8.2), (0.0, 2.0), 0.5);
    (m, rocks)
}

#[test]
fn every_accepted_primitive_keeps_the_body_box_clear_of_the_map() {
    let prims = generate(&PrimitiveSpec::default());
    let params = SurfaceParams::default();
    let shrink = 0.03;
    let body = Cuboid::new(Vector::new(
        (params.body_length_m / 2.0 - shrink) as f32,
        (params.body_width_m / 2.0 - shrink) as f32,
        0.25 - 0.01,
    ));
    let (mut checked, mut accepted) = (0usize, 0usize);
    for seed in [0x9E37_79B9_7F4A_7C15u64, 0x2545_F491_4F6C_DD1D] {
        let (m, _) = clutter(seed);
        let mut trav = TravMap::new(TravParams::default()).unwrap_or_else(|e| panic!("{e}"));
        trav.build(&m, [0.5, 0.5, 0.0])
            .unwrap_or_else(|e| panic!("{e}"));
        let mut lat = SurfaceLattice::new(trav, &prims, params.clone(), 200 * 200)
            .unwrap_or_else(|e| panic!("{e}"));
        lat.prepare_all(&m, (0, 0))
            .unwrap_or_else(|e| panic!("{e}"));
        let res = lat.trav().resolution();
        let nodes = lat.trav().nodes().to_vec();
        let mut out = Vec::new();
        // Every 23rd node, every heading.
        for (n, nd) in nodes.iter().enumerate().step_by(23) {
            if !nd.class.is_drivable() {
                continue;
            }
            for th in 0..prims.angles {
                lat.successors(lat.state(n as u32, th), &mut out);
                for p in prims.primitives.iter().filter(|p| p.start_angle == th) {
                    checked += 1;
                    let end = (nd.ix + p.end[0], nd.iy + p.end[1]);
                    let end_theta = p.end[2].rem_euclid(prims.angles as i32) as u32;
                    let taken = out.iter().any(|&(s, _)| {
                        let (e, t) = lat.decode(s);
                        lat.trav()
                            .node(e)
                            .is_some_and(|en| (en.ix, en.iy) == end && t == end_theta)
                    });
                    if !taken {
                        continue;
                    }
                    accepted += 1;
                    // The map's cells are (ix, iy) -> [ix res, (ix + 1) res).
                    let (ox, oy) = (
                        nd.ix as f64 * res + res / 2.0,
                        nd.iy as f64 * res + res / 2.0,
                    );
                    for q in &p.poses {
                        let (x, y) = (ox + q[0], oy + q[1]);
                        let pose = Pose::from_parts(
                            Vector::new(x as f32, y as f32, 0.45),
                            Rotation::from_rotation_z(q[2] as f32),
                        );
                        let reach = 0.6;
                        let (cx0, cy0) = (
                            ((x - reach) / res).floor() as i32,
                            ((y - reach) / res).floor() as i32,
                        );
                        let (cx1, cy1) = (
                            ((x + reach) / res).floor() as i32,
                            ((y + reach) / res).floor() as i32,
                        );
                        for cx in cx0..=cx1 {
                            for cy in cy0..=cy1 {
                                let (px, py) =
                                    (cx as f64 * res + res / 2.0, cy as f64 * res + res / 2.0);
                                // Beyond the box's reach, or below its
                                // bottom (the floor): parry3d would say no.
                                if (px - x).hypot(py - y) > 0.58 + res {
                                    continue;
                                }
                                for patch in m.cell(cx, cy).iter().filter(|q| q.max >= 0.2) {
                                    let half = Vector::new(
                                        (res / 2.0) as f32,
                                        (res / 2.0) as f32,
                                        ((patch.max - patch.min) / 2.0).max(0.001),
                                    );
                                    let at = Pose::from_parts(
                                        Vector::new(
                                            px as f32,
                                            py as f32,
                                            (patch.max + patch.min) / 2.0,
                                        ),
                                        Rotation::IDENTITY,
                                    );
                                    let hit = parry3d::query::intersection_test(
                                        &pose,
                                        &body,
                                        &at,
                                        &Cuboid::new(half),
                                    )
                                    .unwrap_or_else(|e| panic!("{e:?}"));
                                    assert!(
                                        !hit.intersecting,
                                        "primitive {} from node {n} ({}, {}) heading {th}: the body at ({x:.2}, {y:.2}, {:.2} rad) meets the patch {:.2}..{:.2} m of cell ({cx}, {cy})",
                                        p.id, nd.ix, nd.iy, q[2], patch.min, patch.max
                                    );
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    // The check had work to do: most primitives pass, many are refused.
    assert!(
        accepted > 10_000 && accepted < checked * 9 / 10,
        "{accepted} of {checked}"
    );
}
