//! Traversability classes on synthetic terrain: slope, step, obstacle,
//! unknown, explorable, frontier, and two levels over each other.

use speleo_mapping::mls::{MlsMap, MlsParams, PatchKind};
use speleo_traversability::{Blocked, TravClass, TravMap, TravParams, Window, NONE};

/// Points every 5 cm over `[x0, x1) x [y0, y1)` at height `z(x, y)`.
fn surface(m: &mut MlsMap, x: (f64, f64), y: (f64, f64), z: impl Fn(f64, f64) -> f64) {
    let mut pts = Vec::new();
    let mut px = x.0 + 0.025;
    while px < x.1 {
        let mut py = y.0 + 0.025;
        while py < y.1 {
            pts.push([px, py, z(px, py)]);
            py += 0.05;
        }
        px += 0.05;
    }
    m.insert_points(&pts);
}

/// A vertical column of points over `[x0, x1) x [y0, y1)` from `z0` to `z1`.
fn block(m: &mut MlsMap, x: (f64, f64), y: (f64, f64), z: (f64, f64)) {
    let mut h = z.0;
    while h <= z.1 {
        surface(m, x, y, |_, _| h);
        h += 0.05;
    }
}

fn mls() -> MlsMap {
    MlsMap::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn build(m: &MlsMap, start: [f64; 3]) -> TravMap {
    let mut t = TravMap::new(TravParams::default()).unwrap_or_else(|e| panic!("{e}"));
    t.build(m, start).unwrap_or_else(|e| panic!("{e}"));
    t
}

/// As [`build`], with the deep-drop ring on (off by default).
fn build_with_drop_ring(m: &MlsMap, start: [f64; 3]) -> TravMap {
    let p = TravParams {
        drop_clearance_m: 0.7,
        ..TravParams::default()
    };
    let mut t = TravMap::new(p).unwrap_or_else(|e| panic!("{e}"));
    t.build(m, start).unwrap_or_else(|e| panic!("{e}"));
    t
}

fn class_at(t: &TravMap, x: f64, y: f64, z: f64) -> Option<TravClass> {
    t.node_at(x, y, z, 0.2)
        .and_then(|i| t.node(i))
        .map(|n| n.class)
}

/// Why the node there is an obstacle.
fn blocked_at(t: &TravMap, x: f64, y: f64, z: f64) -> Option<Blocked> {
    t.node_at(x, y, z, 0.2)
        .and_then(|i| t.node(i))
        .map(|n| n.blocked)
}

#[test]
fn flat_ground_is_traversable_and_its_edge_is_frontier() {
    let mut m = mls();
    surface(&mut m, (0.0, 4.0), (0.0, 4.0), |_, _| 0.0);
    let t = build(&m, [2.0, 2.0, 0.0]);
    let s = t.stats();
    assert_eq!(s.nodes, 1600, "{s:?}");
    assert_eq!(class_at(&t, 2.0, 2.0, 0.0), Some(TravClass::Traversable));
    assert_eq!(class_at(&t, 0.05, 2.0, 0.0), Some(TravClass::Frontier));
    // Every border cell and only those.
    assert_eq!(s.frontier, 4 * 40 - 4, "{s:?}");
    assert_eq!(s.obstacle + s.unknown, 0, "{s:?}");
    let n = t.node(0).unwrap_or_else(|| panic!("no node"));
    assert!(n.neighbours.iter().all(|&j| j != NONE));
}

#[test]
fn slopes_beyond_the_limit_are_obstacles() {
    for (deg, drivable) in [(15.0f64, true), (35.0, false)] {
        let mut m = mls();
        let k = deg.to_radians().tan();
        surface(&mut m, (0.0, 2.0), (0.0, 4.0), |_, _| 0.0);
        surface(&mut m, (2.0, 5.0), (0.0, 4.0), |x, _| k * (x - 2.0));
        let t = build(&m, [1.0, 2.0, 0.0]);
        let c = class_at(&t, 3.5, 2.0, 1.5 * k);
        if drivable {
            assert_eq!(c, Some(TravClass::Traversable), "{deg} deg");
            let i = t.node_at(3.5, 2.0, 1.5 * k, 0.2).unwrap_or(NONE);
            let slope = t.node(i).map_or(0.0, |n| n.slope_deg) as f64;
            assert!((slope - deg).abs() < 0.5, "{deg} deg measured {slope}");
        } else {
            // Growth stops at the foot of the ramp, where the robot would
            // stand on it.
            assert_eq!(c, None, "{deg} deg");
            let steep = t
                .nodes()
                .iter()
                .filter(|n| n.class == TravClass::Obstacle && n.slope_deg as f64 > 25.0)
                .inspect(|n| assert!(n.blocked.contains(Blocked::STEEP), "{:?}", n.blocked))
                .count();
            assert!(steep > 0, "no node measured steep");
        }
    }
}

#[test]
fn a_step_higher_than_the_robot_climbs_stops_it() {
    let mut m = mls();
    surface(&mut m, (0.0, 2.0), (0.0, 4.0), |_, _| 0.0);
    surface(&mut m, (2.0, 4.0), (0.0, 4.0), |_, _| 0.3);
    let t = build(&m, [1.0, 2.0, 0.0]);
    // The upper floor is not reached; the ground within the footprint
    // radius (0.4 m) of the ledge is an obstacle (the step lies under the
    // robot) and ends the growth; the ground farther away is not.
    assert_eq!(class_at(&t, 3.0, 2.0, 0.3), None);
    assert_eq!(class_at(&t, 1.95, 2.0, 0.0), None);
    assert_eq!(class_at(&t, 1.65, 2.0, 0.0), Some(TravClass::Obstacle));
    // Too high over the floor for its plane's band: a ledge under the body.
    let b = blocked_at(&t, 1.65, 2.0, 0.0);
    assert!(b.is_some_and(|b| b.contains(Blocked::RAISED)), "{b:?}");
    assert_eq!(class_at(&t, 1.55, 2.0, 0.0), Some(TravClass::Traversable));
    assert_eq!(blocked_at(&t, 1.55, 2.0, 0.0), Some(Blocked::NONE));
    // A 5 cm step is climbed.
    let mut m = mls();
    surface(&mut m, (0.0, 2.0), (0.0, 4.0), |_, _| 0.0);
    surface(&mut m, (2.0, 4.0), (0.0, 4.0), |_, _| 0.05);
    let t = build(&m, [1.0, 2.0, 0.0]);
    assert!(class_at(&t, 3.0, 2.0, 0.05).is_some_and(TravClass::is_drivable));
}

#[test]
fn a_rock_marks_obstacles_only_where_the_body_cannot_avoid_it() {
    let mut m = mls();
    surface(&mut m, (0.0, 6.0), (0.0, 6.0), |_, _| 0.0);
    // A 0.4 m rock, 0.2 m on a side, centred at (3, 3).
    block(&mut m, (2.9, 3.1), (2.9, 3.1), (0.05, 0.4));
    let t = build(&m, [1.0, 1.0, 0.0]);
    assert_eq!(class_at(&t, 3.0, 3.3, 0.0), Some(TravClass::Obstacle));
    assert_eq!(blocked_at(&t, 3.0, 3.3, 0.0), Some(Blocked::BODY));
    // Beyond the inscribed radius (0.3 m) from the rock's edge.
    assert_eq!(class_at(&t, 3.0, 3.5, 0.0), Some(TravClass::Traversable));
    assert_eq!(class_at(&t, 1.0, 1.0, 0.0), Some(TravClass::Traversable));
    // One stray return 0.15 m over the floor is no rock; two are.
    let mut m = mls();
    surface(&mut m, (0.0, 6.0), (0.0, 6.0), |_, _| 0.0);
    m.insert_points(&[[3.05, 3.05, 0.15]]);
    let t = build(&m, [1.0, 1.0, 0.0]);
    assert_eq!(class_at(&t, 3.0, 3.0, 0.0), Some(TravClass::Traversable));
    m.insert_points(&[[3.05, 3.05, 0.16]]);
    let t = build(&m, [1.0, 1.0, 0.0]);
    assert_eq!(class_at(&t, 2.75, 3.05, 0.0), Some(TravClass::Obstacle));
    // A low ceiling is an obstacle too; a high one is not.
    let mut m = mls();
    surface(&mut m, (0.0, 6.0), (0.0, 6.0), |_, _| 0.0);
    surface(&mut m, (2.0, 4.0), (0.0, 6.0), |_, _| 0.5);
    surface(&mut m, (4.0, 6.0), (0.0, 6.0), |_, _| 1.5);
    let t = build(&m, [1.0, 3.0, 0.0]);
    assert_eq!(class_at(&t, 1.0, 3.0, 0.0), Some(TravClass::Traversable));
    assert_eq!(
        class_at(&t, 3.0, 3.0, 0.0),
        None,
        "the roof at 0.5 m blocks"
    );
}

#[test]
fn sparse_data_is_unknown_and_the_ground_before_it_a_frontier() {
    let mut m = mls();
    surface(&mut m, (0.0, 3.0), (0.0, 3.0), |_, _| 0.0);
    // A one-cell-wide ridge at y = 1.5..1.6 across a gap nothing was
    // seen in: on the ridge alone the support points are collinear, no
    // plane. (A gap whose bottom is seen far below is a drop: its rim is
    // no ground to stand on.)
    surface(&mut m, (3.0, 5.0), (1.5, 1.6), |_, _| 0.0);
    let t = build(&m, [1.5, 1.5, 0.0]);
    // Within 0.4 m of the floor the ridge is carried by it, at the border
    // of what was seen; beyond, it is unknown.
    assert_eq!(class_at(&t, 3.15, 1.55, 0.0), Some(TravClass::Frontier));
    assert_eq!(class_at(&t, 3.25, 1.55, 0.0), Some(TravClass::Frontier));
    assert_eq!(class_at(&t, 3.35, 1.55, 0.0), Some(TravClass::Unknown));
    assert_eq!(class_at(&t, 2.55, 1.55, 0.0), Some(TravClass::Traversable));
    let s = t.stats();
    assert_eq!((s.unknown, s.obstacle), (4, 0), "{s:?}");
}

#[test]
fn two_levels_over_each_other_stay_apart_unless_a_ramp_joins_them() {
    let mut m = mls();
    // Ground floor and a deck 2.5 m above over the same cells.
    surface(&mut m, (0.0, 6.0), (0.0, 4.0), |_, _| 0.0);
    surface(&mut m, (0.0, 6.0), (0.0, 4.0), |_, _| 2.5);
    let low = build(&m, [3.0, 2.0, 0.0]);
    let high = build(&m, [3.0, 2.0, 2.5]);
    assert_eq!(low.stats().nodes, 2400);
    assert_eq!(high.stats().nodes, 2400);
    assert!(low.nodes().iter().all(|n| n.patch_z.abs() < 0.01));
    assert!(high.nodes().iter().all(|n| (n.patch_z - 2.5).abs() < 0.01));
    assert_eq!(class_at(&low, 3.0, 2.0, 0.0), Some(TravClass::Traversable));
    // A 14-degree ramp from the ground at x = 6 up to the deck's level at
    // x = 16, and the deck extended to meet it: one graph, two nodes in
    // each cell under the deck.
    let k = 0.25;
    surface(&mut m, (6.0, 16.0), (0.0, 4.0), |x, _| k * (x - 6.0));
    surface(&mut m, (16.0, 18.0), (0.0, 4.0), |_, _| 2.5);
    surface(&mut m, (6.0, 18.0), (4.0, 6.0), |_, _| 2.5);
    surface(&mut m, (0.0, 6.0), (4.0, 6.0), |_, _| 2.5);
    let both = build(&m, [3.0, 2.0, 0.0]);
    let under = both.nodes_in_cell(30, 20).count();
    assert_eq!(under, 2, "ground and deck in cell (30, 20)");
    assert!(class_at(&both, 3.0, 2.0, 2.5).is_some());
}

#[test]
fn a_graph_from_several_starts_holds_the_ground_each_reaches_once() {
    let mut m = mls();
    // Ground floor and a deck 2.5 m above it, no ramp between.
    surface(&mut m, (0.0, 6.0), (0.0, 4.0), |_, _| 0.0);
    surface(&mut m, (0.0, 6.0), (0.0, 4.0), |_, _| 2.5);
    let graph = |starts: &[[f64; 3]]| {
        let mut t = TravMap::new(TravParams::default()).unwrap_or_else(|e| panic!("{e}"));
        t.build_from(&m, starts).map(|_| t)
    };
    let (low, deck, nowhere) = ([3.0, 2.0, 0.0], [3.0, 2.0, 2.5], [30.0, 30.0, 0.0]);
    let one = graph(&[low]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(one.stats().nodes, 2400);
    // Both levels, each patch once; a second start on the same floor and
    // a start over no ground add nothing.
    let all = graph(&[nowhere, low, deck, [1.0, 1.0, 0.0], low]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(all.stats().nodes, 4800);
    assert!(class_at(&all, 3.0, 2.0, 2.5).is_some());
    assert!(class_at(&all, 3.0, 2.0, 0.0).is_some());
    assert!(graph(&[nowhere]).is_err());
    assert!(graph(&[]).is_err());
}

#[test]
fn ground_that_overhangs_a_drop_is_an_obstacle_a_small_step_down_is_not() {
    let mut m = mls();
    // A deck 1.5 m over the floor for x < 4, the floor seen beyond it;
    // for y >= 4 a step of 0.05 m down instead.
    surface(&mut m, (0.0, 4.0), (0.0, 4.0), |_, _| 1.5);
    surface(&mut m, (4.0, 8.0), (0.0, 4.0), |_, _| 0.0);
    surface(&mut m, (0.0, 4.0), (4.0, 8.0), |_, _| 1.5);
    surface(&mut m, (4.0, 8.0), (4.0, 8.0), |_, _| 1.45);
    // Within the footprint's radius (0.4 m) of the edge, in three cells of
    // it or more: the wheels would hang over the drop.
    let t = build(&m, [2.0, 2.0, 1.5]);
    assert_eq!(class_at(&t, 3.75, 2.0, 1.5), Some(TravClass::Obstacle));
    assert!(blocked_at(&t, 3.75, 2.0, 1.5).is_some_and(|b| b.contains(Blocked::DROP)));
    assert_eq!(class_at(&t, 3.65, 2.0, 1.5), Some(TravClass::Traversable));
    let t = build_with_drop_ring(&m, [2.0, 2.0, 1.5]);
    assert_eq!(class_at(&t, 2.0, 2.0, 1.5), Some(TravClass::Traversable));
    // With the deep-drop ring on, a deep drop (0.5 m or more) keeps the
    // rover farther off: three cells of the ring 0.6-0.7 m out show it up
    // to 0.55 m from the edge (the nodes beyond are not grown: obstacles
    // are leaves).
    assert_eq!(class_at(&t, 3.45, 2.0, 1.5), Some(TravClass::Obstacle));
    assert!(blocked_at(&t, 3.45, 2.0, 1.5).is_some_and(|b| b.contains(Blocked::DROP)));
    assert_eq!(class_at(&t, 3.35, 2.0, 1.5), Some(TravClass::Traversable));
    // Down the small step the deck carries on.
    assert_eq!(class_at(&t, 3.95, 6.0, 1.5), Some(TravClass::Traversable));
    assert!(class_at(&t, 5.0, 6.0, 1.45).is_some_and(TravClass::is_drivable));
    // A deck over a floor seen under it (a garage's level over the one
    // below), whose top the rings missed in one column of cells where its
    // underside was seen from below: no drop there.
    let mut m = mls();
    surface(&mut m, (0.0, 2.0), (0.0, 4.0), |_, _| 1.5);
    surface(&mut m, (2.1, 4.0), (0.0, 4.0), |_, _| 1.5);
    surface(&mut m, (0.0, 4.0), (0.0, 4.0), |_, _| 0.0);
    let under: Vec<[f64; 3]> = (0..40)
        .map(|k| [2.05, k as f64 * 0.1 + 0.05, 1.25])
        .collect();
    m.insert_points_seen_from(&under, 0.6);
    let t = build(&m, [1.0, 2.0, 1.5]);
    assert_eq!(class_at(&t, 2.25, 2.1, 1.5), Some(TravClass::Traversable));
    assert_eq!(class_at(&t, 1.85, 2.1, 1.5), Some(TravClass::Traversable));
    // Where nothing of the deck was seen at all over the floor, it is.
    let mut m = mls();
    surface(&mut m, (0.0, 2.0), (0.0, 4.0), |_, _| 1.5);
    surface(&mut m, (2.1, 4.0), (0.0, 4.0), |_, _| 1.5);
    surface(&mut m, (0.0, 4.0), (0.0, 4.0), |_, _| 0.0);
    let t = build(&m, [1.0, 2.0, 1.5]);
    assert_eq!(class_at(&t, 1.75, 2.1, 1.5), Some(TravClass::Obstacle));
    assert_eq!(class_at(&t, 1.65, 2.1, 1.5), Some(TravClass::Traversable));
    // 1.5 m deep, it is a deep drop that crosses the ring 0.6 m out.
    let t = build_with_drop_ring(&m, [1.0, 2.0, 1.5]);
    assert_eq!(class_at(&t, 1.45, 2.1, 1.5), Some(TravClass::Obstacle));
    assert_eq!(class_at(&t, 1.35, 2.1, 1.5), Some(TravClass::Traversable));
}

#[test]
fn a_rim_with_nothing_seen_under_it_is_a_drop_once_a_ray_crossed_it_at_the_decks_height() {
    // A roof 9 m up for x < 4, nothing at all seen past its rim.
    let roof = || {
        let mut m = mls();
        surface(&mut m, (0.0, 4.0), (0.0, 4.0), |_, _| 9.0);
        m
    };
    let t = build(&roof(), [2.0, 2.0, 9.0]);
    assert!(class_at(&t, 3.75, 2.0, 9.0).is_some_and(TravClass::is_drivable));
    // Rays that would have met the roof's plane 0.5 m past the rim met
    // nothing (ExpectedGround marks these): a drop under the wheels.
    let (mut marked, mut rays_over) = (roof(), roof());
    for k in 0..40 {
        for j in 0..5 {
            let (x, y) = (4.05 + 0.1 * j as f64, 0.05 + 0.1 * k as f64);
            assert!(marked.mark_unseen_ground(x, y, 9.0));
            // From a rover standing 0.3 m higher, a ray over the rim says
            // nothing of ground at 9 m.
            assert!(rays_over.mark_unseen_ground(x, y, 9.3));
        }
    }
    let t = build(&marked, [2.0, 2.0, 9.0]);
    assert_eq!(class_at(&t, 3.75, 2.0, 9.0), Some(TravClass::Obstacle));
    assert!(blocked_at(&t, 3.75, 2.0, 9.0).is_some_and(|b| b.contains(Blocked::DROP)));
    assert_eq!(class_at(&t, 3.55, 2.0, 9.0), Some(TravClass::Traversable));
    let t = build(&rays_over, [2.0, 2.0, 9.0]);
    assert!(class_at(&t, 3.75, 2.0, 9.0).is_some_and(TravClass::is_drivable));
}

#[test]
fn a_shallow_ledge_is_kept_off_by_the_footprint_only_a_deep_drop_farther() {
    // A deck 0.3 m over the floor for y < 4 and 1.5 m over it for y >= 4,
    // its edge at x = 4 with the floor seen beyond.
    let mut m = mls();
    surface(&mut m, (0.0, 4.0), (0.0, 4.0), |_, _| 0.3);
    surface(&mut m, (0.0, 4.0), (4.0, 8.0), |_, _| 1.5);
    surface(&mut m, (4.0, 8.0), (0.0, 8.0), |_, _| 0.0);
    let low = build_with_drop_ring(&m, [2.0, 2.0, 0.3]);
    let high = build_with_drop_ring(&m, [2.0, 6.0, 1.5]);
    // 0.45 m from the edge: clear of the footprint's rim (0.4 m); 0.55 m
    // from a deep drop is not.
    assert_eq!(class_at(&low, 3.55, 2.0, 0.3), Some(TravClass::Traversable));
    assert_eq!(class_at(&high, 3.45, 6.0, 1.5), Some(TravClass::Obstacle));
    assert_eq!(
        class_at(&high, 3.35, 6.0, 1.5),
        Some(TravClass::Traversable)
    );
    // No ring, no margin.
    let t = build(&m, [2.0, 6.0, 1.5]);
    assert_eq!(class_at(&t, 3.55, 6.0, 1.5), Some(TravClass::Traversable));
}

#[test]
fn the_same_map_gives_the_same_graph_and_a_full_graph_says_so() {
    let mut m = mls();
    surface(&mut m, (0.0, 4.0), (0.0, 4.0), |x, y| {
        0.05 * (x * 3.0).sin() + 0.03 * y
    });
    block(&mut m, (1.0, 1.2), (1.0, 1.2), (0.0, 0.5));
    let a = build(&m, [3.0, 3.0, 0.09]);
    let b = build(&m, [3.0, 3.0, 0.09]);
    assert_eq!(a.nodes(), b.nodes());
    let mut small = TravMap::new(TravParams {
        max_nodes: 100,
        ..TravParams::default()
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let s = small
        .build(&m, [3.0, 3.0, 0.09])
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(s.full && s.nodes == 100, "{s:?}");
    // Where the limit stopped the growth is marked, and only there: the
    // outermost nodes expanded, around the start.
    assert!(a.nodes().iter().all(|n| !n.cut));
    let cut: Vec<_> = small.nodes().iter().filter(|n| n.cut).collect();
    assert!(!cut.is_empty());
    let d = |n: &speleo_traversability::Node| {
        let p = small.position(n);
        (p[0] - 3.05).hypot(p[1] - 3.05)
    };
    let nearest_cut = cut.iter().map(|n| d(n)).fold(f64::INFINITY, f64::min);
    assert!(nearest_cut > 0.25, "{nearest_cut}");
    assert!(small.nodes().iter().filter(|n| !n.cut).all(|n| d(n) < 0.75));
    assert!(
        small.build(&m, [30.0, 3.0, 0.0]).is_err(),
        "no ground at the start"
    );
}

#[test]
fn growth_in_slices_gives_the_whole_build_and_a_window_keeps_it_in() {
    let mut m = mls();
    surface(&mut m, (0.0, 6.0), (0.0, 4.0), |x, y| {
        0.05 * (x * 3.0).sin() + 0.03 * y
    });
    block(&mut m, (2.0, 2.3), (1.0, 1.3), (0.0, 0.5));
    let whole = build(&m, [3.0, 3.0, 0.09]);
    let mut t = TravMap::new(TravParams::default()).unwrap_or_else(|e| panic!("{e}"));
    t.begin(&m, [3.0, 3.0, 0.09], None)
        .unwrap_or_else(|e| panic!("{e}"));
    let mut slices = 0;
    while !t.grow(&m, 7) {
        slices += 1;
        assert!(!t.is_complete());
    }
    assert!(slices > 100, "{slices} slices");
    // Slices end once their work is spent, within one node's work.
    t.begin(&m, [3.0, 3.0, 0.09], None)
        .unwrap_or_else(|e| panic!("{e}"));
    let mut done = t.work_done();
    while !t.grow(&m, 1000) {
        let slice = t.work_done() - done;
        assert!((1000..1000 + 2500).contains(&slice), "{slice}");
        done = t.work_done();
    }
    assert_eq!(t.nodes(), whole.nodes());
    assert_eq!(t.stats(), whole.stats());
    // A 2 m window around the start: 2 m square of cells, nothing outside,
    // and its edge is not taken for unobserved space.
    let w = Window::around(3.0, 3.0, 1.0, 0.1);
    t.begin(&m, [3.0, 3.0, 0.09], Some(w))
        .unwrap_or_else(|e| panic!("{e}"));
    while !t.grow(&m, 50) {}
    let s = t.stats();
    assert!(s.nodes > 300 && s.nodes <= w.cells(), "{s:?}");
    assert!(t
        .nodes()
        .iter()
        .all(|n| n.ix >= w.min.0 && n.ix <= w.max.0 && n.iy >= w.min.1 && n.iy <= w.max.1));
    assert_eq!(class_at(&t, 2.05, 3.0, 0.09), Some(TravClass::Traversable));
    assert!(t
        .begin(&m, [5.5, 3.0, 0.0], Some(w))
        .is_err_and(|e| e.to_string().contains("no ground patch")));
}

#[test]
fn a_window_indexed_on_a_grid_grows_the_graph_the_hashed_index_grows() {
    let mut m = mls();
    surface(&mut m, (0.0, 6.0), (0.0, 4.0), |x, y| {
        0.05 * (x * 3.0).sin() + 0.03 * y
    });
    block(&mut m, (2.0, 2.3), (1.0, 1.3), (0.0, 0.5));
    // A floor over the first one, reached by nothing: its cells hold a
    // second head only if the first level's growth were to reach it.
    surface(&mut m, (2.5, 4.0), (2.5, 3.5), |_, _| 1.5);
    let w = Window::around(3.0, 3.0, 2.0, 0.1);
    let grow = |max_window_cells| {
        let mut t = TravMap::new(TravParams {
            max_window_cells,
            ..TravParams::default()
        })
        .unwrap_or_else(|e| panic!("{e}"));
        t.begin(&m, [3.0, 3.0, 0.09], Some(w))
            .unwrap_or_else(|e| panic!("{e}"));
        while !t.grow(&m, 300) {}
        t
    };
    let hashed = grow(0);
    let grid = grow(w.cells());
    assert!(hashed.stats().nodes > 1000, "{:?}", hashed.stats());
    assert_eq!(grid.nodes(), hashed.nodes());
    assert_eq!(grid.stats(), hashed.stats());
    assert_eq!(grid.work_done(), hashed.work_done());
    for (x, y) in [(3.0, 3.0), (1.05, 1.55), (4.95, 4.95), (2.15, 1.15)] {
        assert_eq!(
            grid.node_at(x, y, 0.1, 0.3),
            hashed.node_at(x, y, 0.1, 0.3),
            "({x}, {y})"
        );
    }
    // The same grid storage takes a smaller window, and hashes a larger.
    let mut t = grow(w.cells());
    for half in [0.5, 3.0] {
        let w = Window::around(3.0, 3.0, half, 0.1);
        t.begin(&m, [3.0, 3.0, 0.09], Some(w))
            .unwrap_or_else(|e| panic!("{e}"));
        while !t.grow(&m, 300) {}
        let mut h = TravMap::new(TravParams::default()).unwrap_or_else(|e| panic!("{e}"));
        h.begin(&m, [3.0, 3.0, 0.09], Some(w))
            .unwrap_or_else(|e| panic!("{e}"));
        while !h.grow(&m, 300) {}
        assert_eq!(t.nodes(), h.nodes(), "half {half} m");
    }
}

/// The garage's ramp is a 0.25 m slab rising at 14 degrees from the floor:
/// a metre from its foot its underside leaves the floor, and a rover
/// beside it sees the floor under it through the widening gap. The ramp
/// must still be climbable from the floor at its foot.
#[test]
fn a_ramp_slab_over_floor_seen_beneath_it_is_still_climbed() {
    let mut m = mls();
    let rise = 14f64.to_radians().tan();
    // Floor all round, and under the ramp from where its underside leaves
    // the floor: the worst case, where the floor under the slab's low end
    // and its top lie within the MLS's gap and merge into tall patches.
    let seen_under = 3.0 + 0.25 / rise;
    surface(&mut m, (0.0, 3.0), (0.0, 4.0), |_, _| 0.0);
    surface(&mut m, (3.0, 14.0), (0.0, 0.5), |_, _| 0.0);
    surface(&mut m, (3.0, 14.0), (3.5, 4.0), |_, _| 0.0);
    surface(&mut m, (seen_under, 14.0), (0.5, 3.5), |_, _| 0.0);
    // The ramp from x = 3 over y in [0.5, 3.5): top `rise * (x - 3)`.
    let ramp = |x: f64, _: f64| rise * (x - 3.0);
    let mut top = Vec::new();
    let mut px = 3.025;
    while px < 13.0 {
        let mut py = 0.525;
        while py < 3.5 {
            top.push([px, py, ramp(px, py)]);
            py += 0.05;
        }
        px += 0.05;
    }
    m.insert_points(&top);
    // Its sides from the underside up to the top, as the LiDAR sees them
    // from beside the ramp.
    for y in [0.5, 3.45] {
        let mut px = 3.025;
        while px < 13.0 {
            let t = ramp(px, y);
            let mut h = (t - 0.25).max(0.0);
            while h <= t {
                m.insert_points(&[[px, y + 0.025, h]]);
                h += 0.05;
            }
            px += 0.05;
        }
    }
    let t = build(&m, [1.0, 2.0, 0.0]);
    // Half way up, in the middle of the ramp.
    let up = t
        .node_at(8.0, 2.0, ramp(8.0, 2.0), 0.15)
        .and_then(|i| t.node(i));
    assert!(
        up.is_some_and(|n| n.class.is_drivable()),
        "the ramp is not reached: {up:?}"
    );
}

/// Higher up, the LiDAR of a rover beside the ramp sees the slab's
/// underside too, a slab's thickness under its top: within the MLS's gap,
/// so each cell holds one tall patch from underside to top. Where the
/// rings missed the top, only the underside is there: seen from below, it
/// is no drop, and growth bridges it. The ramp is still ground up to its
/// high end, on the patches' tops.
#[test]
fn a_ramp_slab_seen_from_above_and_below_is_climbed_on_its_top() {
    let mut m = mls();
    let rise = 14f64.to_radians().tan();
    let ramp = |x: f64| rise * (x - 3.0);
    surface(&mut m, (0.0, 3.0), (0.0, 4.0), |_, _| 0.0);
    // The upper level at the ramp's high end.
    surface(&mut m, (13.0, 16.0), (0.0, 4.0), |_, _| ramp(13.0));
    // The top from above, the underside from below; the rings missed the
    // top of every fifth column of cells, which holds the underside alone.
    let (mut tops, mut unders) = (Vec::new(), Vec::new());
    let mut px = 3.025;
    while px < 13.0 {
        let mut py = 0.525;
        while py < 3.5 {
            if ((px * 10.0) as i64) % 5 != 2 {
                tops.push([px, py, ramp(px)]);
            }
            unders.push([px, py, ramp(px) - 0.25]);
            py += 0.05;
        }
        px += 0.05;
    }
    // Half the underside before the top, half after.
    let half = unders.len() / 2;
    m.insert_points_seen_from(&unders[..half], -10.0);
    m.insert_points(&tops);
    m.insert_points_seen_from(&unders[half..], -10.0);
    let tall = m
        .cell(m.cell_of(8.0, 2.0).0, m.cell_of(8.0, 2.0).1)
        .iter()
        .any(|q| q.kind == PatchKind::Vertical);
    assert!(tall, "the slab should read as one tall patch");
    let t = build(&m, [1.0, 2.0, 0.0]);
    for x in [5.0f64, 8.0, 12.0, 14.5] {
        let z = ramp(x.min(13.0));
        let n = t.node_at(x, 2.0, z, 0.15).and_then(|i| t.node(i));
        assert!(
            n.is_some_and(|n| n.class.is_drivable() && (n.patch_z as f64 - z).abs() < 0.05),
            "at x = {x}: {n:?}"
        );
    }
}

/// A ramp seen from the floor before it: in every fourth column of cells,
/// points a fifth of a metre under the slope's top, seen from above too (a
/// scan a little misregistered), share a thin patch with the top, whose
/// mean they pull a step under the neighbours' ground. The ground around
/// says such a cell stands at its top: the ramp is climbed.
#[test]
fn a_ramp_whose_cells_hold_points_under_the_top_is_climbed_on_its_top() {
    let mut m = mls();
    let rise = 14f64.to_radians().tan();
    let ramp = |x: f64| rise * (x - 3.0);
    surface(&mut m, (0.0, 3.0), (0.0, 4.0), |_, _| 0.0);
    surface(&mut m, (3.0, 13.0), (0.0, 4.0), |x, _| ramp(x));
    surface(&mut m, (13.0, 16.0), (0.0, 4.0), |_, _| ramp(13.0));
    let mut low = Vec::new();
    let mut px = 3.025;
    while px < 13.0 {
        if ((px * 10.0) as i64) % 4 == 1 {
            let mut py = 0.025;
            while py < 4.0 {
                low.push([px, py, ramp(px) - 0.2]);
                py += 0.05;
            }
        }
        px += 0.05;
    }
    for _ in 0..3 {
        m.insert_points(&low);
    }
    let (ix, iy) = m.cell_of(8.15, 2.0);
    let q = m.cell(ix, iy)[0];
    assert!(
        q.kind == PatchKind::Horizontal && q.ground() == Some(q.mean) && q.top - q.mean > 0.12,
        "the cell should stand at its mean, a step under its top: {q:?}"
    );
    let t = build(&m, [1.0, 2.0, 0.0]);
    for x in [5.0f64, 8.15, 12.0, 14.5] {
        let z = ramp(x.min(13.0));
        let n = t.node_at(x, 2.0, z, 0.15).and_then(|i| t.node(i));
        assert!(
            n.is_some_and(|n| n.class.is_drivable() && (n.ground_z as f64 - z).abs() < 0.05),
            "at x = {x}: {n:?}"
        );
    }
}

/// The tall patch of a ledge's face is ground only at its rim, where the
/// upper floor meets it: from the lower floor it stays a wall.
#[test]
fn a_ledge_face_is_a_wall_from_below() {
    let mut m = mls();
    surface(&mut m, (0.0, 3.0), (0.0, 4.0), |_, _| 0.0);
    surface(&mut m, (3.0, 6.0), (0.0, 4.0), |_, _| 0.6);
    // The face, seen from the lower floor, in the upper floor's first cells.
    let mut face = Vec::new();
    for iy in 0..80 {
        let mut h = 0.0;
        while h <= 0.6 {
            face.push([3.025, 0.025 + iy as f64 * 0.05, h]);
            h += 0.02;
        }
    }
    m.insert_points(&face);
    let t = build(&m, [1.0, 2.0, 0.0]);
    assert!(
        t.node_at(4.5, 2.0, 0.6, 0.15).is_none(),
        "climbed a 0.6 m ledge"
    );
    let from_above = build(&m, [4.5, 2.0, 0.6]);
    assert!(
        from_above.node_at(1.0, 2.0, 0.0, 0.15).is_none(),
        "stepped off it"
    );
}

#[test]
fn a_forbidden_place_becomes_obstacle_except_where_the_rover_stands() {
    let mut m = mls();
    surface(&mut m, (0.0, 4.0), (0.0, 4.0), |_, _| 0.0);
    let mut t = build(&m, [1.0, 2.0, 0.0]);
    // A rock the map cannot see at (2, 2); the rover stands at (1.6, 2).
    let marked = t.forbid([2.0, 2.0, 0.0], 0.5, [1.6, 2.0], 0.2);
    assert_eq!(class_at(&t, 2.0, 2.0, 0.0), Some(TravClass::Obstacle));
    assert_eq!(class_at(&t, 2.4, 2.0, 0.0), Some(TravClass::Obstacle));
    assert_eq!(blocked_at(&t, 2.4, 2.0, 0.0), Some(Blocked::FORBIDDEN));
    // Beyond the radius, and where the rover stands, still drivable.
    assert_eq!(class_at(&t, 2.6, 2.0, 0.0), Some(TravClass::Traversable));
    assert_eq!(class_at(&t, 1.65, 2.0, 0.0), Some(TravClass::Traversable));
    // Roughly the disc less the spared one (0.1 m cells).
    assert!((55..=80).contains(&marked), "{marked}");
    // Another level is not touched.
    assert_eq!(t.forbid([2.0, 2.0, 1.0], 0.5, [0.0, 0.0], 0.0), 0);
}

#[test]
fn the_slope_up_from_a_slide_becomes_obstacle_and_the_way_down_stays() {
    // A 15-degree slope rising along x; the rover slid back at x = 2.
    let k = 0.27;
    let mut m = mls();
    surface(&mut m, (0.0, 5.0), (0.0, 4.0), |x, _| k * x);
    let mut t = build(&m, [0.5, 2.0, k * 0.5]);
    let z = |x: f64| k * x;
    let marked = t.forbid_above([2.0, 2.0, z(2.0)], 1.5, 0.2);
    // More than 0.2 m up the slope, within 1.5 m: barred.
    for x in [2.85, 3.25] {
        assert_eq!(
            class_at(&t, x, 2.0, z(x)),
            Some(TravClass::Obstacle),
            "x {x}"
        );
        assert_eq!(blocked_at(&t, x, 2.0, z(x)), Some(Blocked::FORBIDDEN));
    }
    // The place itself, a little up, and all the way down: drivable.
    for x in [0.55, 1.25, 2.05, 2.55] {
        assert!(
            class_at(&t, x, 2.0, z(x)).is_some_and(TravClass::is_drivable),
            "x {x}"
        );
    }
    // Up the slope beyond the radius: drivable still.
    assert!(class_at(&t, 3.65, 2.0, z(3.65)).is_some_and(TravClass::is_drivable));
    assert!(marked > 50, "{marked}");
}
