//! Candidates on a synthetic corridor: a floor between two walls, seen to
//! x = 12 m, closed behind the rover at x = 0.

use speleo_exploration::{CandidateParams, CandidateScan, CoverageMap, Pass, MAX_CANDIDATES};
use speleo_mapping::mls::{MlsMap, MlsParams};
use speleo_traversability::{TravMap, TravParams, Window};

fn points(m: &mut MlsMap, x: (f64, f64), y: (f64, f64), z: (f64, f64)) {
    let mut pts = Vec::new();
    let mut h = z.0;
    while h <= z.1 + 1e-9 {
        let mut px = x.0 + 0.025;
        while px < x.1 {
            let mut py = y.0 + 0.025;
            while py < y.1 {
                pts.push([px, py, h]);
                py += 0.05;
            }
            px += 0.05;
        }
        h += 0.05;
    }
    m.insert_points(&pts);
}

/// Floor over x in [-1, 12), y in [-1.5, 1.5); walls on both sides and
/// behind x = -1.
fn corridor() -> TravMap {
    let mut m = MlsMap::new(MlsParams::default()).expect("mls");
    points(&mut m, (-1.0, 12.0), (-1.5, 1.5), (0.0, 0.0));
    points(&mut m, (-1.0, 12.0), (-1.7, -1.5), (0.0, 1.5));
    points(&mut m, (-1.0, 12.0), (1.5, 1.7), (0.0, 1.5));
    points(&mut m, (-1.2, -1.0), (-1.7, 1.7), (0.0, 1.5));
    let mut t = TravMap::new(TravParams::default()).expect("trav");
    t.build(&m, [0.0, 0.0, 0.0]).expect("build");
    t
}

fn scan(
    t: &TravMap,
    cov: &CoverageMap,
    rejected: &[[f64; 2]],
    slice: u64,
) -> Vec<speleo_exploration::Candidate> {
    let mut s = CandidateScan::new(CandidateParams::default());
    s.begin([0.0, 0.0], None, None);
    while !s.step(t, cov, rejected, slice) {}
    s.best().to_vec()
}

#[test]
fn the_open_end_of_a_corridor_is_the_best_candidate() {
    let t = corridor();
    let mut cov = CoverageMap::new([0.0, 0.0], 100.0, 0.25);
    cov.mark(0.0, 0.0, 0.2, 3.0);
    let best = scan(&t, &cov, &[], 100);
    assert!(!best.is_empty() && best.len() <= MAX_CANDIDATES);
    // At the open end, where the map stops.
    assert!(best[0].position[0] > 11.5, "{:?}", best[0]);
    assert!(best[0].unexplored_m2 > 0.5, "{:?}", best[0]);
    assert!(best.windows(2).all(|w| w[0].score <= w[1].score));
    // One candidate per place: the open end's patches do not fill the
    // list (each would be tried in turn if that goal failed).
    let radius = CandidateParams::default().rejected_radius_m;
    for (i, a) in best.iter().enumerate() {
        for b in &best[i + 1..] {
            let d = (a.position[0] - b.position[0]).hypot(a.position[1] - b.position[1]);
            assert!(d > radius, "{a:?} and {b:?} are {d:.2} m apart");
        }
    }
    // Slices of any size give the same list.
    assert_eq!(scan(&t, &cov, &[], 1), best);
    assert_eq!(scan(&t, &cov, &[], u64::MAX), best);
}

#[test]
fn a_slice_ends_when_its_work_is_spent_not_after_so_many_nodes() {
    let t = corridor();
    let mut cov = CoverageMap::new([0.0, 0.0], 100.0, 0.25);
    cov.mark(0.0, 0.0, 0.2, 3.0);
    let mut s = CandidateScan::new(CandidateParams::default());
    s.begin([0.0, 0.0], None, None);
    let mut per_slice = Vec::new();
    loop {
        let before = s.census().scanned;
        let done = s.step(&t, &cov, &[], 200);
        per_slice.push(s.census().scanned - before);
        if done {
            break;
        }
    }
    // Nodes passed over at a glance cost one unit each; a scored
    // candidate looks up ~100 cells, so the slices at the open end hold
    // only a few nodes.
    assert!(per_slice.iter().all(|&n| n <= 200), "{per_slice:?}");
    assert!(per_slice.contains(&200), "{per_slice:?}");
    assert!(per_slice.iter().any(|&n| n < 20), "{per_slice:?}");
}

#[test]
fn covered_and_rejected_patches_are_not_candidates() {
    let t = corridor();
    let mut cov = CoverageMap::new([0.0, 0.0], 100.0, 0.25);
    for k in 0..=12 {
        cov.mark(k as f64, 0.0, 0.2, 3.0);
    }
    assert!(scan(&t, &cov, &[], 100).is_empty());
    let cov = CoverageMap::new([0.0, 0.0], 100.0, 0.25);
    let first = scan(&t, &cov, &[], 100)[0];
    let p = [first.position[0], first.position[1]];
    let after = scan(&t, &cov, &[p], 100);
    assert!(after
        .iter()
        .all(|c| (c.position[0] - p[0]).hypot(c.position[1] - p[1]) > 1.5));
}

#[test]
fn a_window_that_cuts_the_corridor_gives_candidates_just_inside_its_border() {
    let t = corridor();
    let cov = CoverageMap::new([0.0, 0.0], 100.0, 0.25);
    let w = Window::around(0.0, 0.0, 8.0, 0.1);
    let mut s = CandidateScan::new(CandidateParams::default());
    s.begin([0.0, 0.0], None, Some(w));
    while !s.step(&t, &cov, &[], 100) {}
    // Nothing within the 1 m margin of the border at x = 8 m ...
    assert!(
        s.best().iter().all(|c| c.position[0] < 7.1),
        "{:?}",
        s.best()
    );
    // ... and the corridor beyond the window is where to go.
    assert!(s.best()[0].position[0] > 6.7, "{:?}", s.best()[0]);
}

#[test]
fn where_a_full_graph_stopped_the_patches_are_candidates_as_at_a_border() {
    let mut m = MlsMap::new(MlsParams::default()).expect("mls");
    points(&mut m, (-1.0, 12.0), (-1.5, 1.5), (0.0, 0.0));
    points(&mut m, (-1.0, 12.0), (-1.7, -1.5), (0.0, 1.5));
    points(&mut m, (-1.0, 12.0), (1.5, 1.7), (0.0, 1.5));
    points(&mut m, (-1.2, -1.0), (-1.7, 1.7), (0.0, 1.5));
    // Room for the corridor's first 5 m or so.
    let mut t = TravMap::new(TravParams {
        max_nodes: 1800,
        ..TravParams::default()
    })
    .expect("trav");
    let s = t.build(&m, [0.0, 0.0, 0.0]).expect("build");
    assert!(s.full, "{s:?}");
    let cov = CoverageMap::new([0.0, 0.0], 100.0, 0.25);
    let best = scan(&t, &cov, &[], 100);
    // The graph ends about 5 m on, well before the corridor's open end:
    // the way on is there.
    assert!(!best.is_empty());
    let reach = t
        .nodes()
        .iter()
        .map(|n| t.position(n)[0])
        .fold(f64::MIN, f64::max);
    assert!(reach < 8.0, "{reach}");
    assert!(best[0].position[0] > reach - 1.0, "{:?}", best[0]);
}

/// A room 4 m long, then a squeeze 1 m wide (the body just fits) seen to
/// x = 6 m: beyond it nothing was seen.
fn squeeze() -> TravMap {
    let mut m = MlsMap::new(MlsParams::default()).expect("mls");
    points(&mut m, (-1.0, 3.0), (-1.5, 1.5), (0.0, 0.0));
    points(&mut m, (3.0, 6.0), (-0.5, 0.5), (0.0, 0.0));
    // The room's walls, its shoulders at x = 3 and the squeeze's sides.
    points(&mut m, (-1.0, 3.2), (-1.7, -1.5), (0.0, 1.5));
    points(&mut m, (-1.0, 3.2), (1.5, 1.7), (0.0, 1.5));
    points(&mut m, (-1.2, -1.0), (-1.7, 1.7), (0.0, 1.5));
    points(&mut m, (3.0, 3.2), (-1.7, -0.5), (0.0, 1.5));
    points(&mut m, (3.0, 3.2), (0.5, 1.7), (0.0, 1.5));
    points(&mut m, (3.0, 6.0), (-0.7, -0.5), (0.0, 1.5));
    points(&mut m, (3.0, 6.0), (0.5, 0.7), (0.0, 1.5));
    let mut t = TravMap::new(TravParams::default()).expect("trav");
    t.build(&m, [0.0, 0.0, 0.0]).expect("build");
    t
}

#[test]
fn the_waist_of_a_squeeze_is_a_candidate_only_when_nothing_roomier_is_left() {
    let t = squeeze();
    let mut cov = CoverageMap::new([0.0, 0.0], 100.0, 0.25);
    cov.mark(0.0, 0.0, 0.2, 3.0);
    let mut s = CandidateScan::new(CandidateParams::default());
    s.begin([0.0, 0.0], None, None);
    while !s.step(&t, &cov, &[], 100) {}
    assert!(s.best().is_empty(), "{:?}", s.best());
    assert!(s.next_pass());
    assert_eq!(s.pass(), Pass::Tight);
    while !s.step(&t, &cov, &[], 100) {}
    let best = s.best();
    assert!(!best.is_empty());
    // At the squeeze's open end, on its middle line.
    assert!(best[0].position[0] > 5.5, "{:?}", best[0]);
    assert!(best[0].position[1].abs() < 0.25, "{:?}", best[0]);
    // Then the crests, and no more passes.
    assert!(s.next_pass());
    assert_eq!(s.pass(), Pass::Crest);
    assert!(!s.next_pass());
    // A new scan starts roomy again.
    s.begin([0.0, 0.0], None, None);
    assert_eq!(s.pass(), Pass::Roomy);
}

#[test]
fn ground_on_another_level_than_the_rover_drove_is_a_candidate_border_or_not() {
    let t = corridor();
    // Driven over the corridor's whole length 3 m higher (a deck over
    // it): the corridor's floor is another level, every part of it a
    // candidate, not only its open end.
    let mut cov = CoverageMap::new([0.0, 0.0], 100.0, 0.25);
    for k in 0..=12 {
        cov.mark(k as f64, 0.0, 3.2, 3.0);
    }
    let best = scan(&t, &cov, &[], 100);
    assert!(
        best.iter().any(|c| c.position[0] < 9.0),
        "inner floor should be a candidate: {best:?}"
    );
    // Never near at all, the inner floor is no candidate: only the border.
    let cov = CoverageMap::new([0.0, 0.0], 100.0, 0.25);
    assert!(scan(&t, &cov, &[], 100)
        .iter()
        .all(|c| c.position[0] > 11.0));
}

/// A 14° ramp up +x from x = -1 to 4 m (a metre and a quarter up), seen
/// 0.6 m onto the level at its top and no farther, as from a rover 1.5 m
/// short of the top, whose LiDAR grazes the level; walls on both sides and
/// behind.
fn ramp_top() -> TravMap {
    let mut m = MlsMap::new(MlsParams::default()).expect("mls");
    let rise = |x: f64| 0.25 * (x.min(4.0) + 1.0);
    let mut pts = Vec::new();
    let mut x = -0.975;
    while x < 4.6 {
        let mut y = -1.475;
        while y < 1.5 {
            pts.push([x, y, rise(x)]);
            y += 0.05;
        }
        for wall_y in [-1.6, 1.6] {
            let mut h = rise(x);
            while h < rise(x) + 1.5 {
                pts.push([x, wall_y, h]);
                h += 0.05;
            }
        }
        x += 0.05;
    }
    m.insert_points(&pts);
    points(&mut m, (-1.2, -1.0), (-1.7, 1.7), (0.0, 1.5));
    let mut t = TravMap::new(TravParams::default()).expect("trav");
    t.build(&m, [2.5, 0.0, rise(2.5)]).expect("build");
    t
}

#[test]
fn a_crest_just_over_the_rover_is_a_candidate_only_when_nothing_else_is() {
    let t = ramp_top();
    let rover_z = 0.25 * 3.5 + 0.19;
    let mut cov = CoverageMap::new([0.0, 0.0], 100.0, 0.25);
    cov.mark(0.0, 0.0, 0.44, 3.0);
    cov.mark(2.5, 0.0, rover_z, 3.0);
    let mut s = CandidateScan::new(CandidateParams::default());
    let passes = |s: &mut CandidateScan, cov: &CoverageMap| {
        s.begin([2.5, 0.0], None, None);
        loop {
            while !s.step(&t, cov, &[], 100) {}
            if !s.best().is_empty() || !s.next_pass() {
                return (s.pass(), s.best().to_vec());
            }
        }
    };
    // The level's edge is too near or covered: neither roomy nor tight
    // goals, but a crest at the top, over the ramp's end.
    let (pass, best) = passes(&mut s, &cov);
    assert_eq!(pass, Pass::Crest);
    assert!(!best.is_empty());
    assert!(best[0].position[0] > 3.8, "{:?}", best[0]);
    assert!(best[0].position[2] > 1.1, "{:?}", best[0]);
    // Refused there: no crest is left.
    let rejected = [[best[0].position[0], best[0].position[1]]];
    s.begin([2.5, 0.0], None, None);
    for _ in 0..3 {
        while !s.step(&t, &cov, &rejected, 100) {}
        assert!(s.best().is_empty(), "{:?}", s.best());
        s.next_pass();
    }
    // Once the rover stood at the top, it is no crest any more, and the
    // census says why each patch was not.
    cov.mark(4.2, 0.0, 1.25 + 0.19, 3.0);
    let (_, best) = passes(&mut s, &cov);
    assert!(best.is_empty(), "{best:?}");
    let c = *s.census();
    assert!(c.crest_stood > 0, "{c:?}");
    assert_eq!(
        c.no_crest,
        c.crest_not_border + c.crest_low + c.crest_out_of_reach + c.crest_stood,
        "{c:?}"
    );
}
