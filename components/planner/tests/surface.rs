//! The multi-level lattice on synthetic surfaces: up a ramp to another
//! level, never onto a level it cannot reach, around a rock, the same plan
//! twice.

use speleo_mapping::mls::{MlsMap, MlsParams};
use speleo_planner::arastar::{AraParams, AraStar, Lattice, Progress, WORK_PER_UNIT};
use speleo_planner::primitives::{generate, PrimitiveSpec};
use speleo_planner::surface::{SurfaceLattice, SurfaceParams};
use speleo_traversability::{TravMap, TravParams, Window};

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

/// A floor, a 14-degree ramp up 1 m and an upper floor, 3 m wide, with a
/// bridge 2.5 m over the floor that nothing leads to.
fn world() -> MlsMap {
    let mut m = MlsMap::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
    surface(&mut m, (0.0, 5.0), (0.0, 3.0), |_, _| 0.0);
    surface(&mut m, (5.0, 9.0), (0.0, 3.0), |x, _| 0.25 * (x - 5.0));
    surface(&mut m, (9.0, 13.0), (0.0, 3.0), |_, _| 1.0);
    surface(&mut m, (1.0, 4.0), (1.0, 2.0), |_, _| 2.5);
    m
}

struct Plan {
    cost: Option<u32>,
    first: Option<u32>,
    path: Vec<[f64; 3]>,
    expansions: u64,
    /// The most expansions one step made.
    step_expansions_max: u64,
    step_expansions_min: u64,
    /// The most lattice work a step did.
    step_work_max: u64,
}

fn plan(m: &MlsMap, start: [f64; 4], goal: [f64; 4]) -> Plan {
    plan_with(m, start, goal, SurfaceParams::default())
}

fn plan_with(m: &MlsMap, start: [f64; 4], goal: [f64; 4], params: SurfaceParams) -> Plan {
    plan_in_steps(m, start, goal, params, 500)
}

/// Plan with ARA* steps of `units` units.
fn plan_in_steps(
    m: &MlsMap,
    start: [f64; 4],
    goal: [f64; 4],
    params: SurfaceParams,
    units: u32,
) -> Plan {
    let mut trav = TravMap::new(TravParams::default()).unwrap_or_else(|e| panic!("{e}"));
    trav.build(m, [start[0], start[1], start[2]])
        .unwrap_or_else(|e| panic!("{e}"));
    let prims = generate(&PrimitiveSpec::default());
    let node = |p: [f64; 4]| trav.node_at(p[0], p[1], p[2], 0.3);
    let (Some(s), Some(g)) = (node(start), node(goal)) else {
        return Plan {
            cost: None,
            first: None,
            path: Vec::new(),
            expansions: 0,
            step_expansions_max: 0,
            step_expansions_min: 0,
            step_work_max: 0,
        };
    };
    let bin = |yaw: f64| speleo_planner::sbpl::angle_to_bin(yaw, 16);
    let mut lat =
        SurfaceLattice::new(trav, &prims, params, 200 * 200).unwrap_or_else(|e| panic!("{e}"));
    lat.prepare_all(m, (g, bin(goal[3])))
        .unwrap_or_else(|e| panic!("{e}"));
    let mut a = AraStar::new(lat.max_state_count(), lat.max_successors());
    a.start(
        &lat,
        lat.state(s, bin(start[3])),
        lat.goal_state(),
        AraParams::default(),
    );
    let mut first = None;
    let mut step_expansions_max = 0;
    let mut step_expansions_min = u64::MAX;
    let mut step_work_max = 0;
    let cost = loop {
        let before = a.stats().expansions;
        let work_before = lat.work();
        let progress = a.step(&lat, units);
        let expanded = a.stats().expansions - before;
        step_expansions_max = step_expansions_max.max(expanded);
        if matches!(progress, Progress::Searching) {
            step_expansions_min = step_expansions_min.min(expanded);
        }
        step_work_max = step_work_max.max(lat.work() - work_before);
        match progress {
            Progress::Searching => {}
            Progress::Solution { cost, .. } => {
                first.get_or_insert(cost);
            }
            Progress::Optimal { cost } => break Some(cost),
            Progress::NoPath | Progress::Idle => break None,
        }
    };
    let mut states = Vec::new();
    a.path(&mut states);
    Plan {
        cost,
        first,
        path: lat.path_positions(&states),
        expansions: a.stats().expansions,
        step_expansions_max,
        step_expansions_min,
        step_work_max,
    }
}

#[test]
fn a_search_step_does_at_most_its_units_of_work() {
    // The executive's budget for the planner is a number of units, not a
    // time: a step of 24 does 24 units' lattice work, and at most one
    // expansion more, whatever the map. Expansions by the walls test their
    // footprints, so those steps expand fewer states.
    let m = world();
    let (start, goal) = ([1.0, 1.5, 0.0, 0.0], [11.5, 1.5, 1.0, 0.0]);
    let p = plan_in_steps(&m, start, goal, SurfaceParams::default(), 24);
    assert!(p.cost.is_some(), "no plan");
    assert!(p.expansions > 1_000, "{} expansions", p.expansions);
    let budget = 24 * WORK_PER_UNIT;
    assert!(
        p.step_work_max >= budget && p.step_work_max < budget + 4 * WORK_PER_UNIT,
        "{} work in a step",
        p.step_work_max
    );
    assert!(
        p.step_expansions_min < p.step_expansions_max,
        "{} to {} expansions a step",
        p.step_expansions_min,
        p.step_expansions_max
    );
    // The same plan as in larger steps: the units cut the work, not the result.
    assert_eq!(p.cost, plan(&m, start, goal).cost);
}

#[test]
fn the_plan_climbs_the_ramp_to_the_upper_floor_and_repeats_bit_for_bit() {
    let m = world();
    let (start, goal) = ([1.0, 1.5, 0.0, 0.0], [11.5, 1.5, 1.0, 0.0]);
    let p = plan(&m, start, goal);
    let cost = p.cost.unwrap_or_else(|| panic!("no plan"));
    // At least the straight 10.55 m at 0.3 m/s.
    assert!(cost as f64 >= 10.55 / 0.3 * 1000.0 * 0.99, "{cost} ms");
    assert!(p
        .first
        .is_some_and(|f| f >= cost && f as f64 <= 3.0 * cost as f64));
    let last = p.path[p.path.len() - 1];
    assert!(
        (last[2] - 1.0).abs() < 0.05 && (last[0] - 11.5).abs() < 0.1,
        "{last:?}"
    );
    // On the ground all the way: on the ramp, the ramp's height.
    for q in &p.path {
        let ground = (0.25 * (q[0] - 5.0)).clamp(0.0, 1.0);
        assert!((q[2] - ground).abs() < 0.06, "{q:?}");
    }
    let again = plan(&m, start, goal);
    assert_eq!((again.cost, again.expansions), (p.cost, p.expansions));
    assert_eq!(again.path, p.path);
}

#[test]
fn a_level_nothing_leads_to_is_not_planned_to() {
    let m = world();
    // The bridge over the floor is a separate level: no node there.
    let p = plan(&m, [1.0, 1.5, 0.0, 0.0], [2.5, 1.5, 2.5, 0.0]);
    assert_eq!(p.cost, None);
    // Under the bridge, on the floor, is fine (2.5 m of headroom).
    let p = plan(
        &m,
        [1.0, 1.5, 0.0, 0.0],
        [3.0, 1.5, 0.0, 90.0f64.to_radians()],
    );
    assert!(p.cost.is_some());
}

#[test]
fn a_lattice_prepared_in_slices_equals_one_prepared_at_once() {
    // With the edge term and the rock limit too, whose nodes are checked
    // fewer to a unit.
    let edges = SurfaceParams {
        edge_weight: 2.0,
        ..SurfaceParams::default()
    };
    let rocks = SurfaceParams {
        max_bump_m: 0.06,
        ..SurfaceParams::default()
    };
    let both = SurfaceParams {
        max_bump_m: 0.06,
        ..edges.clone()
    };
    for params in [SurfaceParams::default(), edges, rocks, both] {
        prepared_in_slices_equals_prepared_at_once(&params);
    }
}

fn prepared_in_slices_equals_prepared_at_once(params: &SurfaceParams) {
    let m = world();
    let lattice = |units: usize| {
        let mut trav = TravMap::new(TravParams::default()).unwrap_or_else(|e| panic!("{e}"));
        trav.build(&m, [1.0, 1.5, 0.0])
            .unwrap_or_else(|e| panic!("{e}"));
        let goal = trav
            .node_at(11.5, 1.5, 1.0, 0.3)
            .unwrap_or_else(|| panic!("no goal node"));
        let prims = generate(&PrimitiveSpec::default());
        let mut lat = SurfaceLattice::new(trav, &prims, params.clone(), 200 * 200)
            .unwrap_or_else(|e| panic!("{e}"));
        lat.begin((goal, 0)).unwrap_or_else(|e| panic!("{e}"));
        let mut steps = 0;
        while !lat.prepare(&m, units) {
            steps += 1;
        }
        (lat, steps)
    };
    let (whole, _) = lattice(usize::MAX);
    let (sliced, steps) = lattice(1);
    assert!(steps > 300, "{steps} steps");
    assert_eq!(whole.state_count(), sliced.state_count());
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for s in 0..whole.state_count() as u32 {
        assert_eq!(whole.heuristic(s), sliced.heuristic(s), "state {s}");
        if s % 97 == 0 {
            whole.successors(s, &mut a);
            sliced.successors(s, &mut b);
            assert_eq!(a, b, "state {s}");
        }
    }
    // A lattice whose graph is regrown must be prepared again.
    let (mut again, _) = lattice(usize::MAX);
    let _ = again.trav_mut();
    assert!(!again.is_ready());
    again.successors(0, &mut a);
    assert!(a.is_empty());
}

#[test]
fn a_level_under_two_slabs_and_a_roof_is_planned_on() {
    // Three decks 3 m apart, each slab seen from below and above, and a
    // roof: six patches in every cell. Planning on any deck must see
    // only what lies in its own body band.
    let mut m = MlsMap::new(MlsParams {
        max_patches_per_cell: 8,
        ..MlsParams::default()
    })
    .unwrap_or_else(|e| panic!("{e}"));
    surface(&mut m, (0.0, 6.0), (0.0, 3.0), |_, _| 0.0);
    for deck in [3.0, 6.0] {
        surface(&mut m, (0.0, 6.0), (0.0, 3.0), |_, _| deck - 0.4);
        surface(&mut m, (0.0, 6.0), (0.0, 3.0), |_, _| deck);
    }
    surface(&mut m, (0.0, 6.0), (0.0, 3.0), |_, _| 8.75);
    for z in [0.0, 3.0, 6.0] {
        let p = plan(&m, [1.0, 1.5, z, 0.0], [5.0, 1.5, z, 0.0]);
        assert!(p.cost.is_some(), "no plan on the deck at {z} m");
    }
}

/// From (1, 2) to (9, 2) on `m`, heading +x: the plan with the default
/// parameters and the one with `wary`, and their costs.
fn across_the_floor(m: &MlsMap, wary: SurfaceParams) -> (Plan, Plan, u32, u32) {
    let (start, goal) = ([1.0, 2.0, 0.0, 0.0], [9.0, 2.0, 0.0, 0.0]);
    let plain = plan(m, start, goal);
    let wary = plan_with(m, start, goal, wary);
    let (Some(c0), Some(c1)) = (plain.cost, wary.cost) else {
        panic!("no plan");
    };
    (plain, wary, c0, c1)
}

/// A floor 10 m long over `y`, with a rock `height` tall and 0.4 m
/// across at (5, 2): a dome seen from above.
fn floor_with_a_dome(y: (f64, f64), height: f64) -> MlsMap {
    let mut m = MlsMap::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
    surface(&mut m, (0.0, 10.0), y, |x, y| {
        let r2 = (x - 5.0).powi(2) + (y - 2.0).powi(2);
        height * (1.0 - r2 / 0.04).max(0.0)
    });
    m
}

/// Least distance from `c` (x, y) to the path's segments, m.
fn closest_approach(p: &Plan, c: [f64; 2]) -> f64 {
    p.path
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let t = (((c[0] - a[0]) * dx + (c[1] - a[1]) * dy) / (dx * dx + dy * dy).max(1e-12))
                .clamp(0.0, 1.0);
            (a[0] + t * dx - c[0]).hypot(a[1] + t * dy - c[1])
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_clearance_weight_keeps_the_path_farther_from_a_rock() {
    let mut m = MlsMap::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
    surface(&mut m, (0.0, 10.0), (0.0, 4.0), |_, _| 0.0);
    // A 0.4 m rock, 0.5 m tall, just off the straight line.
    let mut h = 0.05;
    while h <= 0.5 {
        surface(&mut m, (4.8, 5.2), (1.2, 1.6), |_, _| h);
        h += 0.05;
    }
    let closest = |p: &Plan| closest_approach(p, [5.0, 1.4]);
    let (plain, wary, c0, c1) = across_the_floor(
        &m,
        SurfaceParams {
            clearance_weight: 5.0,
            ..SurfaceParams::default()
        },
    );
    assert!(c1 >= c0, "{c1} < {c0}");
    assert!(
        closest(&wary) > closest(&plain),
        "{:.2} m, {:.2} m without the weight",
        closest(&wary),
        closest(&plain)
    );
}

#[test]
fn a_bump_weight_takes_the_path_round_a_rock_the_map_lets_it_cross() {
    // A rock 0.4 m across and 8 cm tall on the straight line, a dome
    // seen from above: under the body's clearance and no more than a step
    // between cells, so the map lets the rover over it.
    let m = floor_with_a_dome((0.0, 4.0), 0.08);
    let (start, goal) = ([1.0, 2.0, 0.0, 0.0], [9.0, 2.0, 0.0, 0.0]);
    let closest = |p: &Plan| closest_approach(p, [5.0, 2.0]);
    let (plain, wary, c0, c1) = across_the_floor(
        &m,
        SurfaceParams {
            bump_weight: 3.0,
            ..SurfaceParams::default()
        },
    );
    assert!(c1 > c0, "{c1} <= {c0}");
    // Straight over it without the weight; with it, the body's inscribed
    // circle (0.35 m) clear of its top.
    assert!(closest(&plain) < 0.2, "{:.2} m", closest(&plain));
    assert!(closest(&wary) > 0.4, "{:.2} m", closest(&wary));
    // Flat ground costs nothing more.
    let mut flat = MlsMap::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
    surface(&mut flat, (0.0, 10.0), (0.0, 4.0), |_, _| 0.0);
    let on_flat = |w: f64| {
        plan_with(
            &flat,
            start,
            goal,
            SurfaceParams {
                bump_weight: w,
                ..SurfaceParams::default()
            },
        )
        .cost
    };
    assert_eq!(on_flat(0.0), on_flat(3.0));
}

#[test]
fn turning_round_at_a_ramps_foot_costs_what_turning_on_the_ramp_does() {
    // Just short of the foot, to face the other way where it stands: the
    // node is level, but the legs on the ramp side dig into the ramp.
    let m = world();
    let free = SurfaceParams {
        turn_slope_weight_per_deg: 0.0,
        ..SurfaceParams::default()
    };
    for x in [4.7, 4.8] {
        let start = [x, 1.5, 0.0, 0.0];
        let goal = [x, 1.5, 0.0, std::f64::consts::PI];
        let p = plan(&m, start, goal);
        let q = plan_with(&m, start, goal, free.clone());
        assert!(p.cost.is_some() && q.cost.is_some(), "no plan");
        assert!(q.cost < p.cost, "at {x}: {:?} {:?}", q.cost, p.cost);
    }
    // Far from the ramp, turning costs the same either way.
    let start = [2.0, 1.5, 0.0, 0.0];
    let goal = [2.0, 1.5, 0.0, std::f64::consts::PI];
    assert_eq!(
        plan(&m, start, goal).cost,
        plan_with(&m, start, goal, free).cost
    );
}

/// A deck 1.5 m up, 3 m wide, with its open side at y = 3 over a floor
/// the map has seen; `holes`: a cell of the deck in every metre along
/// y = 1.5 that the rings missed, through which the floor was seen.
fn deck(holes: bool) -> MlsMap {
    let mut m = MlsMap::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
    let hole =
        |x: f64, y: f64| holes && x.fract() >= 0.5 && x.fract() < 0.6 && (1.5..1.6).contains(&y);
    let mut pts = Vec::new();
    for i in 0..200 {
        for j in 0..60 {
            let (x, y) = (0.025 + 0.05 * i as f64, 0.025 + 0.05 * j as f64);
            pts.push([x, y, if hole(x, y) { 0.0 } else { 1.5 }]);
        }
    }
    m.insert_points(&pts);
    surface(&mut m, (0.0, 10.0), (3.0, 5.0), |_, _| 0.0);
    m
}

#[test]
fn an_edge_weight_keeps_the_path_off_a_decks_open_side() {
    let m = deck(false);
    let (start, goal) = ([1.0, 2.6, 1.5, 0.0], [9.0, 2.6, 1.5, 0.0]);
    let plain = plan(&m, start, goal);
    let wary = plan_with(
        &m,
        start,
        goal,
        SurfaceParams {
            edge_weight: 2.0,
            ..SurfaceParams::default()
        },
    );
    let (Some(c0), Some(c1)) = (plain.cost, wary.cost) else {
        panic!("no plan");
    };
    assert!(c1 > c0, "{c1} <= {c0}");
    // Farthest from the edge the path gets in the middle of the deck.
    let off_edge = |p: &Plan| {
        p.path
            .iter()
            .filter(|q| (3.0..=7.0).contains(&q[0]))
            .map(|q| 3.0 - q[1])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    assert!(off_edge(&plain) < 0.5, "{:.2} m", off_edge(&plain));
    // Out of the reach (0.8 m between cell centres) where it can.
    assert!(off_edge(&wary) >= 0.7, "{:.2} m", off_edge(&wary));
}

#[test]
fn a_hole_in_the_deck_the_graph_bridges_is_no_edge() {
    // Single cells of the deck where only the floor under it was seen,
    // on the line: too few under a footprint to make it hang over a drop,
    // and bridged by the graph, so they are ground. The open side, 1.5 m
    // from the line, is beyond the reach: the edge costs nothing.
    let m = deck(true);
    let (start, goal) = ([1.0, 1.55, 1.5, 0.0], [9.0, 1.55, 1.5, 0.0]);
    let cost = |w: f64| {
        plan_with(
            &m,
            start,
            goal,
            SurfaceParams {
                edge_weight: w,
                ..SurfaceParams::default()
            },
        )
        .cost
    };
    assert!(cost(0.0).is_some(), "no plan");
    assert_eq!(cost(0.0), cost(2.0));
}

#[test]
fn the_body_keeps_its_wheels_off_a_decks_open_side() {
    // The deck's nodes 0.35 m from its open side have 0.4 m footprints
    // on it but for one cell: the graph holds them. The body as on board
    // (1.0 x 0.8 m with its margin) does not fit there.
    let m = deck(false);
    let start = [1.0, 2.0, 1.5, 0.0];
    let plain = SurfaceParams {
        body_length_m: 1.0,
        body_width_m: 0.8,
        ..SurfaceParams::default()
    };
    let wary = SurfaceParams {
        body_drop_cells: 3,
        ..plain.clone()
    };
    let along = [6.0, 2.65, 1.5, 0.0];
    let facing = [6.0, 2.55, 1.5, std::f64::consts::FRAC_PI_2];
    let inside = [6.0, 2.55, 1.5, 0.0];
    for goal in [along, facing, inside] {
        let p = plan_with(&m, start, goal, plain.clone());
        assert!(p.cost.is_some(), "no plain plan to {goal:?}");
    }
    // Along the edge at 0.35 m the body's side is over it; 0.45 m from
    // it and facing it, its nose.
    assert!(plan_with(&m, start, along, wary.clone()).cost.is_none());
    assert!(plan_with(&m, start, facing, wary.clone()).cost.is_none());
    // 0.1 m further in, the whole way keeps the body on the deck.
    let p = plan_with(&m, start, inside, wary);
    assert!(p.cost.is_some(), "no plan");
    let nearest = p
        .path
        .iter()
        .map(|q| q[1])
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(nearest <= 2.6, "{nearest:.2}");
}

/// The traversability graph of `m` grown from (1, 2) on its floor.
fn graph_from_the_floor(m: &MlsMap) -> TravMap {
    let mut trav = TravMap::new(TravParams::default()).unwrap_or_else(|e| panic!("{e}"));
    trav.build(m, [1.0, 2.0, 0.0])
        .unwrap_or_else(|e| panic!("{e}"));
    trav
}

/// A lattice over `trav` with `params`, prepared to `goal` on `m`.
fn prepared(m: &MlsMap, trav: TravMap, params: SurfaceParams, goal: (u32, u32)) -> SurfaceLattice {
    let prims = generate(&PrimitiveSpec::default());
    let mut lat =
        SurfaceLattice::new(trav, &prims, params, 200 * 200).unwrap_or_else(|e| panic!("{e}"));
    lat.prepare_all(m, goal).unwrap_or_else(|e| panic!("{e}"));
    lat
}

#[test]
fn a_goal_over_a_rock_shows_the_rocks_height() {
    // The 8 cm dome of the test above: what the exploration's goal check
    // reads under the body at its top, and nothing on the floor round it.
    let m = floor_with_a_dome((0.0, 4.0), 0.08);
    let trav = graph_from_the_floor(&m);
    let node = |x: f64, y: f64| {
        trav.node_at(x, y, 0.0, 0.3)
            .unwrap_or_else(|| panic!("no node at {x}, {y}"))
    };
    let (rock, floor) = (node(5.0, 2.0), node(8.0, 2.0));
    let params = SurfaceParams {
        bump_weight: 3.0,
        ..SurfaceParams::default()
    };
    let lat = prepared(&m, trav, params, (rock, 0));
    let over_rock = lat.bump_m(rock).unwrap_or(f32::NAN);
    assert!((0.06..=0.09).contains(&over_rock), "{over_rock} m");
    assert_eq!(lat.bump_m(floor), Some(0.0));
    // Counted from the floor round the body, the rock reads its height
    // from its top too, where the node's plane passes through it.
    let params = SurfaceParams {
        max_bump_m: 0.1,
        ..SurfaceParams::default()
    };
    let trav = graph_from_the_floor(&m);
    let lat = prepared(&m, trav, params, (floor, 0));
    let from_floor = lat.rock_m(rock).unwrap_or(f32::NAN);
    assert!((0.07..=0.09).contains(&from_floor), "{from_floor} m");
    assert_eq!(lat.rock_m(floor), Some(0.0));
}

#[test]
fn a_rock_over_the_bump_limit_is_gone_round_or_not_passed_at_all() {
    // The 8 cm dome again, with no bump cost: only the limit keeps the
    // body off it.
    let limit = SurfaceParams {
        max_bump_m: 0.05,
        ..SurfaceParams::default()
    };
    let (start, goal) = ([1.0, 2.0, 0.0, 0.0], [9.0, 2.0, 0.0, 0.0]);
    let wide = floor_with_a_dome((0.0, 4.0), 0.08);
    let plain = plan(&wide, start, goal);
    let limited = plan_with(&wide, start, goal, limit.clone());
    assert!(plain.cost.is_some() && limited.cost.is_some(), "no plan");
    let closest = |p: &Plan| closest_approach(p, [5.0, 2.0]);
    assert!(closest(&plain) < 0.2, "{:.2} m", closest(&plain));
    // The body's inscribed circle (0.35 m) clear of where the dome rises
    // more than the limit.
    assert!(closest(&limited) > 0.4, "{:.2} m", closest(&limited));
    // No detour for a rock under the limit.
    let under = floor_with_a_dome((0.0, 4.0), 0.03);
    let over_low_rock = plan_with(&under, start, goal, limit.clone());
    assert!(
        closest(&over_low_rock) < 0.2,
        "{:.2} m",
        closest(&over_low_rock)
    );
    // In a corridor 0.8 m wide there is no way round: no plan, where the
    // map alone lets the rover over.
    let narrow = floor_with_a_dome((1.6, 2.4), 0.08);
    assert!(plan(&narrow, start, goal).cost.is_some(), "no plan");
    assert_eq!(plan_with(&narrow, start, goal, limit).cost, None);
}

#[test]
fn a_floor_curving_up_into_a_wall_is_no_rock() {
    // A tube's floor: level in the middle, rising ever more steeply
    // towards both sides. Over a node's support plane the rise under the
    // body's side reads as a bump; over the plane of the ground the
    // wheels stand on it is none.
    let mut m = MlsMap::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
    surface(&mut m, (0.0, 10.0), (0.0, 4.0), |_, y| {
        let side = ((y - 2.0).abs() - 0.6).max(0.0);
        0.8 * side * side
    });
    let trav = graph_from_the_floor(&m);
    let across: Vec<(f64, u32)> = (0..16)
        .map(|k| 2.0 + 0.1 * k as f64)
        .filter_map(|y| {
            let z = 0.8 * (y - 2.6).max(0.0).powi(2);
            Some((y, trav.node_at(5.0, y, z, 0.3)?))
        })
        .collect();
    let floor = across[0].1;
    let params = SurfaceParams {
        bump_weight: 1.0,
        max_bump_m: 0.06,
        ..SurfaceParams::default()
    };
    let lat = prepared(&m, trav, params, (floor, 0));
    let most = |f: &dyn Fn(u32) -> Option<f32>| {
        across
            .iter()
            .map(|&(_, j)| f(j).unwrap_or(f32::NAN))
            .fold(0.0f32, f32::max)
    };
    // Nodes up to 0.3 m into the rise (steeper, the slope refuses them).
    assert!(across.len() >= 9, "{} nodes across", across.len());
    let bump = most(&|j| lat.bump_m(j));
    let rock = most(&|j| lat.rock_m(j));
    assert!(bump > 0.08, "bump {bump} m");
    assert_eq!(rock, 0.0);
    assert!(across.iter().all(|&(_, j)| !lat.over_a_rock(j)));
}

/// A search on the graph grown in `window` around (2, 1.5) on an 8 m by
/// 3 m floor, from (1, 1.5) to (3.3, 1.5): whether it ran a primitive into
/// the window's border.
fn met_the_window_edge(window: Window) -> bool {
    let mut m = MlsMap::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
    surface(&mut m, (0.0, 8.0), (0.0, 3.0), |_, _| 0.0);
    let mut trav = TravMap::new(TravParams::default()).unwrap_or_else(|e| panic!("{e}"));
    trav.begin(&m, [1.0, 1.5, 0.0], Some(window))
        .unwrap_or_else(|e| panic!("{e}"));
    while !trav.grow(&m, 1000) {}
    let (s, g) = match (
        trav.node_at(1.0, 1.5, 0.0, 0.3),
        trav.node_at(3.3, 1.5, 0.0, 0.3),
    ) {
        (Some(s), Some(g)) => (s, g),
        other => panic!("no start or goal node: {other:?}"),
    };
    let lat = prepared(&m, trav, SurfaceParams::default(), (g, 0));
    let mut a = AraStar::new(lat.max_state_count(), lat.max_successors());
    a.start(
        &lat,
        lat.state(s, 0),
        lat.goal_state(),
        AraParams::default(),
    );
    loop {
        match a.step(&lat, 500) {
            Progress::Searching | Progress::Solution { .. } => {}
            Progress::Optimal { .. } => break,
            other => panic!("no plan across the floor: {other:?}"),
        }
    }
    lat.met_window_edge()
}

#[test]
fn a_search_tells_whether_it_ran_into_the_growth_windows_border() {
    // The goal 0.2 m inside a 3 m window: primitives from round it leave
    // the window. In a window larger than the floor they meet only the
    // floor's own edges, which a larger window would not move.
    assert!(met_the_window_edge(Window::around(2.0, 1.5, 1.5, 0.1)));
    assert!(!met_the_window_edge(Window::around(4.0, 1.5, 6.0, 0.1)));
}
