//! Multi-level surface map: two levels over the same cells, walls,
//! a full table and eviction, bad points, the scan pose, determinism.

mod common;

use common::{Rng, TUBE};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use speleo_mapping::mls::{self, MlsMap, MlsParams, PatchKind};
use speleo_mapping::ParamsError;

fn map(params: MlsParams) -> MlsMap {
    MlsMap::new(params).expect("valid parameters")
}

/// A floor at z = 0 and an upper floor at z = 2.5 over x, y in [0, 4),
/// and a wall at x = 4.05 from the floor to the upper floor, sampled every
/// 2.5 cm with 1 cm height noise.
fn two_level_scene() -> Vec<[f64; 3]> {
    let mut rng = Rng(1);
    let mut pts = Vec::new();
    let step = 0.025;
    for i in 0..160 {
        for j in 0..160 {
            let (x, y) = (i as f64 * step + 0.001, j as f64 * step + 0.001);
            pts.push([x, y, 0.01 * rng.gauss()]);
            pts.push([x, y, 2.5 + 0.01 * rng.gauss()]);
        }
    }
    for j in 0..160 {
        for k in 0..=100 {
            pts.push([4.05, j as f64 * step + 0.001, k as f64 * step]);
        }
    }
    pts
}

#[test]
fn two_levels_stay_apart_in_the_same_cells() {
    let mut m = map(MlsParams::default());
    let s = m.insert_points(&two_level_scene());
    assert_eq!(s.inserted, s.points);
    let mut cells = 0;
    m.for_each_in_region([0.0, 0.0], [3.99, 3.99], |ix, iy, patches| {
        cells += 1;
        assert_eq!(patches.len(), 2, "cell ({ix}, {iy}): {patches:?}");
        let (floor, upper) = (patches[0], patches[1]);
        assert_eq!(floor.kind, PatchKind::Horizontal);
        assert_eq!(upper.kind, PatchKind::Horizontal);
        assert_eq!((floor.count, upper.count), (16, 16));
        // 16 points of 1 cm noise: the mean is within 4 sigma / 4.
        assert!(floor.mean.abs() < 0.01, "{floor:?}");
        assert!((upper.mean - 2.5).abs() < 0.01, "{upper:?}");
        assert!(floor.max < upper.min);
        let expected_var = 0.02f32 * 0.02 / 16.0;
        assert!((floor.variance - expected_var).abs() < 1e-9);
    });
    assert_eq!(cells, 40 * 40);
}

#[test]
fn a_cell_read_through_its_slot_is_the_cell_read_by_its_coordinates() {
    let mut m = map(MlsParams::default());
    m.insert_points(&two_level_scene());
    for (ix, iy) in [
        (0, 0),
        (12, 30),
        (39, 39),
        (40, 5),
        (41, 5),
        (-1, 0),
        (500, 500),
    ] {
        m.prefetch_cell(ix, iy);
        let read = m.cell_slot(ix, iy).map_or(&[][..], |s| m.patches_at(s));
        assert_eq!(read, m.cell(ix, iy), "cell ({ix}, {iy})");
        assert_eq!(m.cell_slot(ix, iy).is_some(), !m.cell(ix, iy).is_empty());
    }
    // A slot of a larger map is none of a smaller one's: no patches, no
    // panic.
    let small = map(MlsParams {
        max_cells: 4,
        ..MlsParams::default()
    });
    let far = m.cell_slot(39, 39).expect("a known cell");
    assert!(small.patches_at(far).is_empty());
}

#[test]
fn a_wall_becomes_vertical_patches() {
    let mut m = map(MlsParams::default());
    m.insert_points(&two_level_scene());
    let (ix, _) = m.cell_of(4.05, 0.0);
    assert_eq!(ix, 40);
    for iy in 0..40 {
        let patches = m.cell(ix, iy);
        assert_eq!(patches.len(), 1, "{patches:?}");
        let p = patches[0];
        assert_eq!(p.kind, PatchKind::Vertical);
        assert!(p.min.abs() < 1e-6 && (p.max - 2.5).abs() < 1e-6, "{p:?}");
    }
    // A shallow slope (30 degrees over a cell: 6 cm) stays horizontal.
    let mut m = map(MlsParams::default());
    let slope: Vec<[f64; 3]> = (0..40)
        .map(|k| {
            let x = 10.0 + k as f64 * 0.0025;
            [x, 0.05, (x - 10.0) * 0.577]
        })
        .collect();
    m.insert_points(&slope);
    let p = m.cell(100, 0);
    assert_eq!(p.len(), 1);
    assert_eq!(p[0].kind, PatchKind::Horizontal);
}

#[test]
fn the_scan_pose_moves_the_points() {
    let mut m = map(MlsParams::default());
    // A 1 m square of floor 1 m below a sensor at (5, 0, 1), yawed 90 deg.
    let scan: Vec<[f32; 3]> = (0..100)
        .map(|k| {
            [
                (k % 10) as f32 * 0.1 + 0.05,
                (k / 10) as f32 * 0.1 + 0.05,
                -1.0,
            ]
        })
        .collect();
    let pose = Isometry3::from_parts(
        Translation3::new(5.0, 0.0, 1.0),
        UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2),
    );
    let s = m.insert_scan(&pose, &scan);
    assert_eq!(s.inserted, 100);
    assert_eq!(m.stats().cells, 100);
    // Sensor x becomes map y, sensor y becomes map -x.
    let p = m.cell(m.cell_of(5.0 - 0.05, 0.05).0, 0);
    assert_eq!(p.len(), 1);
    assert!(p[0].mean.abs() < 1e-6, "{:?}", p[0]);
    assert!(m.cell(50, 0).is_empty());
    assert_eq!(m.cell(49, 9).len(), 1);
    assert_eq!(m.cell(40, 9).len(), 1);
}

#[test]
fn a_full_map_reports_it_does_not_grow_and_keeps_a_region() {
    let params = MlsParams {
        max_cells: 50,
        ..MlsParams::default()
    };
    let mut m = map(params);
    let memory = m.stats().memory_bytes;
    // 20 x 20 cells, row by row: the first 50 cells seen fill the table.
    let pts: Vec<[f64; 3]> = (0..400)
        .map(|k| {
            [
                (k % 20) as f64 * 0.1 + 0.05,
                (k / 20) as f64 * 0.1 + 0.05,
                0.0,
            ]
        })
        .collect();
    let s = m.insert_points(&pts);
    assert_eq!((s.inserted, s.dropped_map_full), (50, 350));
    let st = m.stats();
    assert!(st.full);
    assert_eq!((st.cells, st.patches, st.dropped_points), (50, 50, 350));
    assert_eq!(st.memory_bytes, memory);
    // Known cells still take points.
    assert_eq!(m.insert_points(&pts[..50]).inserted, 50);
    assert_eq!(m.cell(0, 0)[0].count, 2);

    // Keep the cells within 0.35 m of (0.5, 0.15).
    let (center, radius) = ([0.5, 0.15], 0.35);
    let mut expected = Vec::new();
    m.for_each_cell(|ix, iy, _| {
        let [cx, cy] = m.cell_center(ix, iy);
        if (cx - center[0]).hypot(cy - center[1]) <= radius {
            expected.push((ix, iy));
        }
    });
    assert!(!expected.is_empty() && expected.len() < 50);
    let evicted = m.keep_region(center, radius);
    assert_eq!(evicted, 50 - expected.len());
    let mut kept = Vec::new();
    m.for_each_cell(|ix, iy, p| {
        assert_eq!(p.len(), 1);
        kept.push((ix, iy));
    });
    assert_eq!(kept, expected);
    let st = m.stats();
    assert_eq!(
        (st.cells, st.patches, st.full),
        (expected.len(), expected.len(), false)
    );
    assert_eq!(st.memory_bytes, memory);
    for ix in 0..20 {
        for iy in 0..20 {
            assert_eq!(!m.cell(ix, iy).is_empty(), expected.contains(&(ix, iy)));
        }
    }
    // The freed room takes new cells again, up to the capacity.
    let s = m.insert_points(&pts);
    assert_eq!(m.stats().cells, 50);
    assert_eq!(s.dropped_map_full, 400 - 50);
    m.clear();
    assert_eq!(m.stats().cells, 0);
    assert!(m.cell(0, 0).is_empty());
    assert_eq!(m.stats().memory_bytes, memory);
}

#[test]
fn a_cell_with_the_most_patches_drops_new_levels() {
    let mut m = map(MlsParams {
        max_patches_per_cell: 2,
        ..MlsParams::default()
    });
    let s = m.insert_points(&[[0.05, 0.05, 0.0], [0.05, 0.05, 1.0], [0.05, 0.05, 2.0]]);
    assert_eq!((s.inserted, s.dropped_patch_limit), (2, 1));
    assert_eq!(m.stats().dropped_points, 1);
    assert_eq!(m.cell(0, 0).len(), 2);
}

#[test]
fn a_cell_under_a_garages_roof_ramp_keeps_every_level_by_default() {
    // The floor, the first ramp, the first level's slab, the second's,
    // the roof ramp and the roof's underside: six surfaces over one cell
    // (the garage's under its roof ramp, with a slab's edge), each seen
    // from the side that sees it.
    let mut m = map(MlsParams::default());
    let levels = [
        (0.0, true),
        (1.2, true),
        (3.0, true),
        (6.0, true),
        (7.1, true),
        (8.75, false),
    ];
    for (z, above) in levels {
        let sensor = if above { z + 0.6 } else { z - 2.0 };
        m.insert_points_seen_from(&[[0.05, 0.05, z], [0.05, 0.05, z + 0.005]], sensor);
    }
    assert_eq!(m.stats().dropped_points, 0);
    let cell = m.cell(0, 0);
    assert_eq!(cell.len(), levels.len(), "{cell:?}");
    // The roof ramp's top is ground to stand on.
    assert!(mls::ground_near(cell, 7.1, 0.1).is_some_and(|g| (g - 7.1).abs() < 0.01));
}

#[test]
fn bad_points_are_counted_not_inserted() {
    let mut m = map(MlsParams::default());
    let pts = [
        [f64::NAN, 0.0, 0.0],
        [0.0, f64::INFINITY, 0.0],
        [0.0, 0.0, f64::NEG_INFINITY],
        [1e12, 0.0, 0.0],
        [0.0, 0.0, 1e9],
        [0.05, 0.05, 0.0],
    ];
    let s = m.insert_points(&pts);
    assert_eq!((s.non_finite, s.out_of_range, s.inserted), (3, 2, 1));
    let st = m.stats();
    assert_eq!((st.cells, st.non_finite, st.out_of_range), (1, 3, 2));
    let scan = [[f32::NAN, 0.0, 0.0], [1.0, 1.0, 1.0]];
    let s = m.insert_scan(&Isometry3::identity(), &scan);
    assert_eq!((s.non_finite, s.inserted), (1, 1));
    // A non-finite pose poisons nothing: every point is refused.
    let bad_pose = Isometry3::translation(f64::NAN, 0.0, 0.0);
    let s = m.insert_scan(&bad_pose, &scan);
    assert_eq!((s.non_finite, s.inserted), (2, 0));
    assert_eq!(m.insert_points(&[]), Default::default());
    assert_eq!(m.stats().cells, 2);
    // Zero capacities drop everything, counted.
    let mut z = map(MlsParams {
        max_cells: 0,
        ..MlsParams::default()
    });
    assert_eq!(z.insert_points(&pts).dropped_map_full, 1);
    assert!(z.stats().full);
    let mut z = map(MlsParams {
        max_patches_per_cell: 0,
        ..MlsParams::default()
    });
    assert_eq!(z.insert_points(&pts).dropped_patch_limit, 1);
    assert!(matches!(
        MlsMap::new(MlsParams {
            resolution_m: 0.0,
            ..MlsParams::default()
        }),
        Err(ParamsError::NotPositive("resolution_m"))
    ));
    // Regions: bad or inverted bounds visit nothing.
    let mut n = 0;
    m.for_each_in_region([f64::NAN, 0.0], [1.0, 1.0], |_, _, _| n += 1);
    // Huge bounds cost no more than the cells in use.
    m.for_each_in_region([-1e300, -1e300], [1e300, 1e300], |_, _, _| n += 10);
    assert_eq!(n, 20);
    n = 0;
    m.for_each_in_region([1.0, 1.0], [0.0, 0.0], |_, _, _| n += 1);
    assert_eq!(n, 0);
    assert_eq!(m.keep_region([f64::NAN, 0.0], 1.0), 0);
    assert_eq!(m.stats().cells, 2);
}

#[test]
fn regions_are_visited_row_by_row() {
    let mut m = map(MlsParams::default());
    let pts: Vec<[f64; 3]> = [(3, 1), (0, 0), (2, 0), (1, 1), (-1, 0)]
        .iter()
        .map(|&(ix, iy)| [ix as f64 * 0.1 + 0.05, iy as f64 * 0.1 + 0.05, 0.0])
        .collect();
    m.insert_points(&pts);
    let mut seen = Vec::new();
    m.for_each_in_region([0.0, 0.0], [0.35, 0.15], |ix, iy, _| seen.push((ix, iy)));
    assert_eq!(seen, vec![(0, 0), (2, 0), (1, 1), (3, 1)]);
}

/// Every field of every patch, as bits, in storage order.
fn fingerprint(m: &MlsMap) -> Vec<(i32, i32, Vec<[u32; 6]>)> {
    let mut out = Vec::new();
    m.for_each_cell(|ix, iy, p| {
        let bits = p
            .iter()
            .map(|q| {
                [
                    q.mean.to_bits(),
                    q.variance.to_bits(),
                    q.min.to_bits(),
                    q.max.to_bits(),
                    q.count,
                    q.kind as u32,
                ]
            })
            .collect();
        out.push((ix, iy, bits));
    });
    out
}

#[test]
fn the_same_scans_give_bit_identical_maps() {
    let mut rng = Rng(3);
    let origins = common::tube_origins(3);
    let scans: Vec<_> = origins
        .iter()
        .map(|o| common::tube_scan(*o, 0.02, &mut rng))
        .collect();
    let build = || {
        let mut m = map(MlsParams::default());
        for (o, s) in origins.iter().zip(&scans) {
            let pose = Isometry3::from_parts(
                Translation3::new(o[0], o[1], o[2]),
                UnitQuaternion::from_euler_angles(0.01, -0.02, 0.3),
            );
            m.insert_scan(&pose, s);
        }
        m
    };
    let (a, b) = (build(), build());
    assert_eq!(a.stats(), b.stats());
    assert!(a.stats().cells > 1000);
    assert_eq!(fingerprint(&a), fingerprint(&b));
    // And after eviction and clearing, the same again.
    let (mut a, mut b) = (a, b);
    a.keep_region([1.0, 0.0], 3.0);
    b.keep_region([1.0, 0.0], 3.0);
    assert_eq!(fingerprint(&a), fingerprint(&b));
    let _ = TUBE;
}

#[test]
fn one_call_gives_the_map_of_one_point_after_the_other() {
    // Insertion looks cells up ahead of applying points (a pipeline): the
    // map must be that of applying them one by one, storage order, counts
    // and drops included. Points hop between a few cells (a new cell is
    // met again while its first point is still in flight), with levels to
    // fuse, bad points, a patch limit and a table that fills up.
    let mut rng = Rng(11);
    let mut pts = Vec::new();
    for k in 0..4000 {
        let cell = (rng.uniform() * 70.0) as i32;
        let (ix, iy) = (cell % 9 - 4, cell / 9 - 3);
        let z = match k % 5 {
            0 => 0.01 * rng.gauss(),
            1 => 2.0 + 0.3 * rng.gauss(),
            2 => 0.8 * rng.uniform(),
            3 => 4.0 + rng.uniform(),
            _ => 6.0 * rng.uniform() - 3.0,
        };
        pts.push([ix as f64 * 0.1 + 0.05, iy as f64 * 0.1 + 0.05, z]);
        match k % 97 {
            13 => pts.push([f64::NAN, 0.0, 0.0]),
            41 => pts.push([0.0, 1e12, 0.0]),
            _ => {}
        }
    }
    let params = MlsParams {
        max_cells: 60,
        max_patches_per_cell: 3,
        ..MlsParams::default()
    };
    let mut whole = map(params.clone());
    let mut single = map(params.clone());
    let s = whole.insert_points(&pts);
    for p in &pts {
        single.insert_points(std::slice::from_ref(p));
    }
    assert!(s.dropped_map_full > 0 && s.dropped_patch_limit > 0, "{s:?}");
    assert!(s.non_finite > 0 && s.out_of_range > 0, "{s:?}");
    assert_eq!(whole.stats(), single.stats());
    assert_eq!(fingerprint(&whole), fingerprint(&single));
    // The same through a scan pose, in pieces of every size up to the
    // lookahead and beyond.
    let pose = Isometry3::from_parts(
        Translation3::new(0.3, -0.2, 0.1),
        UnitQuaternion::from_euler_angles(0.02, -0.01, 0.7),
    );
    let scan: Vec<[f32; 3]> = pts
        .iter()
        .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32])
        .collect();
    let mut whole = map(params.clone());
    let mut pieces = map(params.clone());
    let mut single = map(params);
    whole.insert_scan(&pose, &scan);
    let mut rest = &scan[..];
    let mut n = 1;
    while !rest.is_empty() {
        let (a, b) = rest.split_at(n.min(rest.len()));
        pieces.insert_scan(&pose, a);
        rest = b;
        n = n % 40 + 1;
    }
    for p in &scan {
        single.insert_scan(&pose, std::slice::from_ref(p));
    }
    assert_eq!(whole.stats(), single.stats());
    assert_eq!(fingerprint(&whole), fingerprint(&single));
    assert_eq!(fingerprint(&pieces), fingerprint(&single));
}

#[test]
fn the_tube_has_floor_and_vault_in_the_same_cells_and_vertical_walls() {
    // 20 revolutions 1 m apart along the tube. The upper lasers (up to
    // +10.67 deg) reach the vault (z = +2 on the axis) about 14 m ahead,
    // where the floor (z = -1.2) is seen by the lower ones.
    let mut rng = Rng(5);
    let mut m = map(MlsParams::default());
    for o in common::tube_origins(20) {
        let scan = common::tube_scan(o, 0.0, &mut rng);
        m.insert_scan(&Isometry3::translation(o[0], o[1], o[2]), &scan);
    }
    let (mut two_levels, mut near_axis) = (0, 0);
    m.for_each_in_region([2.0, -0.3], [18.0, 0.29], |ix, iy, p| {
        near_axis += 1;
        for q in p {
            let floor = (q.mean - TUBE.floor_z as f32).abs() < 1e-3;
            let vault = q.mean > 1.97 && q.mean < 2.0;
            assert!(floor || vault, "({ix}, {iy}): {p:?}");
            assert_eq!(q.kind, PatchKind::Horizontal);
        }
        if p.len() == 2 {
            two_levels += 1;
            assert!(p[0].mean < 0.0 && p[1].mean > 1.9, "{p:?}");
        }
    });
    assert!(two_levels >= 50, "{two_levels} of {near_axis}");
    // The side walls between z = -0.6 and 0.6 (|y| in [1.9, 2)) are steep.
    let (mut vertical, mut wall) = (0, 0);
    for (lo, hi) in [([2.0, 1.9], [18.0, 1.99]), ([2.0, -2.0], [18.0, -1.91])] {
        m.for_each_in_region(lo, hi, |_, _, p| {
            wall += 1;
            vertical += p.iter().any(|q| q.kind == PatchKind::Vertical) as u32;
        });
    }
    assert!(
        wall > 100 && vertical * 10 >= wall * 8,
        "{vertical} of {wall}"
    );
}

#[test]
fn a_slab_seen_only_from_below_is_an_underside_until_seen_from_above() {
    let mut m = map(MlsParams::default());
    // The underside of a slab whose top is at 1.0, from a sensor at 0.5.
    let under = [[0.05, 0.05, 0.75], [0.05, 0.05, 0.76]];
    m.insert_points_seen_from(&under, 0.5);
    let p = m.cell(0, 0)[0];
    assert!(!p.seen_from_above);
    assert!(p.underside_for(1.0), "{p:?}");
    assert!(
        !p.underside_for(0.8),
        "at its own height it is what is seen"
    );
    // What stands at 1.0 cannot be known from it, at 0.75 it is ground.
    assert_eq!(mls::ground_near(m.cell(0, 0), 1.0, 0.3), None);
    assert!(mls::ground_near(m.cell(0, 0), 0.75, 0.1).is_some());
    // The top, seen from a sensor over it: one tall patch standing at it.
    m.insert_points_seen_from(&[[0.05, 0.05, 1.0], [0.05, 0.05, 1.01]], 1.5);
    let p = m.cell(0, 0)[0];
    assert!(p.seen_from_above && !p.underside_for(1.0));
    assert!(
        p.ground().is_some_and(|g| (g - 1.005).abs() < 1e-3),
        "{p:?}"
    );
    // Points of a sensor unknown count as seen from above.
    let mut m = map(MlsParams::default());
    m.insert_points(&under);
    assert!(m.cell(0, 0)[0].seen_from_above);
}

#[test]
fn a_thin_floor_seen_from_both_sides_stands_at_its_top_a_lip_over_a_floor_does_not() {
    // A garage slab 0.2 m thick (under the vertical threshold): many
    // underside points from the level under it, a few top points from the
    // level it floors. Its mean lies near the underside; one stands on
    // its top.
    let mut m = map(MlsParams::default());
    let under: Vec<[f64; 3]> = (0..20)
        .map(|k| [0.05, 0.05, 2.8 + k as f64 * 1e-3])
        .collect();
    m.insert_points_seen_from(&under, 0.5);
    m.insert_points_seen_from(&[[0.05, 0.05, 3.0], [0.05, 0.05, 3.01]], 3.5);
    let p = m.cell(0, 0)[0];
    assert_eq!(p.kind, PatchKind::Horizontal, "{p:?}");
    assert!(p.mean < 2.9, "{p:?}");
    assert!(
        p.ground().is_some_and(|g| (g - 3.005).abs() < 1e-3),
        "{p:?}"
    );
    // A floor with a lip 0.2 m over it, both seen from a sensor over
    // them: the floor is what one stands on, not the lip.
    let mut m = map(MlsParams::default());
    let floor: Vec<[f64; 3]> = (0..20).map(|k| [0.05, 0.05, k as f64 * 1e-3]).collect();
    m.insert_points_seen_from(&floor, 0.7);
    m.insert_points_seen_from(&[[0.05, 0.05, 0.2], [0.05, 0.05, 0.21]], 0.7);
    let p = m.cell(0, 0)[0];
    assert!(p.ground().is_some_and(|g| g < 0.1), "{p:?}");
}
