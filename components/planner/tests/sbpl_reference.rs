//! SBPL's own optimal costs (../shared/data/sbpl, README there), and ARA*
//! against an exhaustive search on small random lattices.

use std::path::PathBuf;

use speleo_planner::arastar::{AraParams, AraStar, Lattice, Progress};
use speleo_planner::sbpl::{parse_env, SbplEnv, SbplLattice};
use speleo_planner::{mprim, INFINITE_COST};

fn data() -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sbpl");
    if d.is_dir() {
        Some(d)
    } else {
        eprintln!("SKIPPED: {} is absent", d.display());
        None
    }
}

fn lattice(dir: &std::path::Path, env: &str, prims: &str) -> SbplLattice {
    let read =
        |f: &str| std::fs::read_to_string(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    let env = parse_env(&read(env)).unwrap_or_else(|e| panic!("{env}: {e}"));
    let prims = mprim::parse(&read(prims)).unwrap_or_else(|e| panic!("{prims}: {e}"));
    SbplLattice::new(env, &prims).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs ARA* to the end: (first cost, optimal cost), or None.
fn plan(l: &SbplLattice, eps: f64) -> Option<(u32, u32)> {
    plan_in_steps(l, eps, 10_000)
}

/// The same, `units` units of work a step.
fn plan_in_steps(l: &SbplLattice, eps: f64, units: u32) -> Option<(u32, u32)> {
    let mut a = AraStar::new(l.state_count(), l.max_successors());
    a.start(
        l,
        l.start_state(),
        l.goal_state(),
        AraParams {
            initial_eps: eps,
            eps_step: 0.2,
        },
    );
    let mut first = None;
    loop {
        match a.step(l, units) {
            Progress::Searching => {}
            Progress::Solution { cost, .. } => {
                first.get_or_insert(cost);
            }
            Progress::Optimal { cost } => return Some((*first.get_or_insert(cost), cost)),
            Progress::NoPath | Progress::Idle => return None,
        }
    }
}

#[test]
fn optimal_costs_match_sbpl() {
    let Some(d) = data() else { return };
    for (env, prims, expected) in [
        ("env1.cfg", "pr2.mprim", Some(8348)),
        ("env1.cfg", "mprim_unic_sideback.mprim", Some(575)),
        ("env1.cfg", "all_file.mprim", Some(527)),
        ("env1.cfg", "unicycle_noturninplace.mprim", None),
        ("env2.cfg", "pr2_10cm.mprim", Some(184_564)),
    ] {
        let l = lattice(&d, env, prims);
        let got = plan(&l, 3.0);
        assert_eq!(got.map(|g| g.1), expected, "{env} + {prims}");
        if let Some((first, best)) = got {
            assert!(
                first >= best && first as f64 <= 3.0 * best as f64,
                "{first} vs {best}"
            );
        }
    }
    let l = lattice(&d, "env1.cfg", "pr2.mprim");
    assert_eq!((l.start.0, l.start.1, l.start.2), (4, 4, 0));
    assert_eq!((l.goal.0, l.goal.1, l.goal.2), (13, 11, 0));
}

/// Cheapest cost from the start to every state by relaxing every edge
/// until nothing changes (Bellman-Ford): no heap, no heuristic.
fn exhaustive(l: &SbplLattice) -> u32 {
    let n = l.state_count();
    let mut g = vec![INFINITE_COST; n];
    g[l.start_state() as usize] = 0;
    let mut out = Vec::new();
    loop {
        let mut changed = false;
        for s in 0..n as u32 {
            if g[s as usize] == INFINITE_COST {
                continue;
            }
            l.successors(s, &mut out);
            for &(t, c) in &out {
                let ng = g[s as usize].saturating_add(c);
                if ng < g[t as usize] {
                    g[t as usize] = ng;
                    changed = true;
                }
            }
        }
        if !changed {
            return g[l.goal_state() as usize];
        }
    }
}

/// A unicycle set of 8 headings: forward one cell, forward turns, and a
/// costly backward step, written as SBPL would.
fn small_prims() -> mprim::MprimFile {
    let mut text =
        String::from("resolution_m: 0.1\nnumberofangles: 8\ntotalnumberofprimitives: 32\n");
    let dirs = [
        (1, 0),
        (1, 1),
        (0, 1),
        (-1, 1),
        (-1, 0),
        (-1, -1),
        (0, -1),
        (1, -1),
    ];
    let mut id = 0;
    for a in 0..8i32 {
        let (dx, dy) = dirs[a as usize];
        for (ex, ey, et, mult) in [
            (dx, dy, a, 1),
            (dx, dy, a + 1, 1),
            (dx, dy, a - 1, 2),
            (-dx, -dy, a, 5),
        ] {
            let th = a as f64 * std::f64::consts::TAU / 8.0;
            text += &format!(
                "primID: {id}\nstartangle_c: {a}\nendpose_c: {ex} {ey} {et}\nadditionalactioncostmult: {mult}\nintermediateposes: 3\n0 0 {th}\n{} {} {th}\n{} {} {th}\n",
                ex as f64 * 0.05,
                ey as f64 * 0.05,
                ex as f64 * 0.1,
                ey as f64 * 0.1
            );
            id += 1;
        }
    }
    mprim::parse(&text).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn ara_star_finds_the_exhaustive_optimum_on_random_small_lattices() {
    let prims = small_prims();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut rand = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let (mut solved, mut unsolvable) = (0, 0);
    for _ in 0..60 {
        let (w, h) = (6 + (rand() % 6) as usize, 6 + (rand() % 6) as usize);
        // Free cells cost 0..3; a fifth are obstacles.
        let grid: Vec<u8> = (0..w * h)
            .map(|_| match rand() % 10 {
                0 | 1 => 5,
                r => (r % 4) as u8,
            })
            .collect();
        let mut env = SbplEnv {
            width: w,
            height: h,
            angles: 8,
            obsthresh: 5,
            cost_inscribed_thresh: 5,
            cost_possibly_circumscribed_thresh: 0,
            cellsize_m: 0.1,
            nominalvel_mps: 1.0,
            time_to_turn_45_s: 0.5,
            start: [0.05, 0.05, 0.0],
            goal: [
                (w as f64 - 0.5) * 0.1,
                (h as f64 - 0.5) * 0.1,
                (rand() % 8) as f64 * 0.785,
            ],
            grid,
        };
        env.grid[0] = 0;
        env.grid[w * h - 1] = 0;
        let l = SbplLattice::new(env, &prims).unwrap_or_else(|e| panic!("{e}"));
        let truth = exhaustive(&l);
        // Work cut into the smallest steps (a round's end too) changes
        // nothing.
        assert_eq!(plan(&l, 2.5), plan_in_steps(&l, 2.5, 1));
        match plan(&l, 2.5) {
            Some((first, best)) => {
                assert_eq!(best, truth);
                assert!(first as f64 <= 2.5 * truth as f64);
                solved += 1;
            }
            None => {
                assert_eq!(truth, INFINITE_COST);
                unsolvable += 1;
            }
        }
    }
    assert!(
        solved > 20 && unsolvable > 0,
        "{solved} solved, {unsolvable} not"
    );
}
