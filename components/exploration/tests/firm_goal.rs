//! Goals on seen ground: a slab seen to its rim, nothing past it.

use speleo_exploration::{firm_goal, FirmGoalParams};
use speleo_mapping::mls::{MlsMap, MlsParams};
use speleo_traversability::{TravMap, TravParams};

/// Points every 5 cm over `[x0, x1) x [y0, y1)` at height `z`.
fn floor(m: &mut MlsMap, x: (f64, f64), y: (f64, f64), z: f64) {
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

fn graph(m: &MlsMap) -> TravMap {
    let mut t = TravMap::new(TravParams::default()).expect("trav");
    t.build(m, [1.0, 3.0, 0.0]).expect("build");
    t
}

fn node_at(t: &TravMap, x: f64, y: f64) -> u32 {
    t.node_at(x, y, 0.0, 0.2).expect("a patch there")
}

#[test]
fn a_goal_on_a_rim_moves_inward_until_the_body_stands_on_seen_ground() {
    // A roof 6 m square seen to its rim at x = 6; past it, nothing.
    let mut m = MlsMap::new(MlsParams::default()).expect("mls");
    floor(&mut m, (0.0, 6.0), (0.0, 6.0), 0.0);
    let t = graph(&m);
    let p = FirmGoalParams::default();
    let rim = node_at(&t, 5.95, 3.05);
    let (goal, work) = firm_goal(&t, rim, 0.45, &p);
    let at = t.position(t.node(goal).expect("goal"));
    // Body radius 0.45 m: its centre 0.45 m or more inside the rim, and
    // moved straight in.
    assert!(at[0] <= 6.0 - p.body_radius_m && at[0] > 5.2, "{at:?}");
    assert!((at[1] - 3.05).abs() < 0.11, "{at:?}");
    assert!(work > 0);
    // A goal with seen ground all round stays where it is.
    let inner = node_at(&t, 3.05, 3.05);
    assert_eq!(firm_goal(&t, inner, 0.45, &p).0, inner);
}

#[test]
fn a_goal_that_cannot_move_onto_seen_ground_moves_to_the_least_unseen() {
    // A strip 0.5 m wide: every patch has unseen ground under the body.
    let mut m = MlsMap::new(MlsParams::default()).expect("mls");
    floor(&mut m, (0.0, 6.0), (2.75, 3.25), 0.0);
    let mut t = TravMap::new(TravParams {
        inscribed_radius_m: 0.2,
        footprint_radius_m: 0.25,
        ..TravParams::default()
    })
    .expect("trav");
    t.build(&m, [1.0, 3.0, 0.0]).expect("build");
    let p = FirmGoalParams::default();
    // On the strip's side: the walk goes across to its middle and stops
    // at the far side; the goal is the patch with fewest unseen cells.
    let side = node_at(&t, 3.05, 3.2);
    let (goal, _) = firm_goal(&t, side, 0.15, &p);
    let at = t.position(t.node(goal).expect("goal"));
    assert!((at[1] - 3.0).abs() < 0.11, "{at:?}");
    assert!((at[0] - 3.05).abs() < 0.11, "{at:?}");
}
