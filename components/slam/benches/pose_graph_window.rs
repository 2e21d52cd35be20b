//! The back end's cost per keyframe on a graph shaped like the 240 m
//! out-and-back drive: a chain of keyframes 1 m apart, registrations to
//! the two previous ones, a loop closure from every returning keyframe to
//! its outbound twin, inclination factors through the bias, and an active
//! window of the newest keyframes (older ones in rigid sub-maps of five, as
//! on board). Measures what one new keyframe costs: the structural analysis
//! (`Solver::new`) and one Levenberg-Marquardt iteration, with the on-board
//! window and with every keyframe free.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use nalgebra::{Matrix3, Matrix6, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use speleo_slam::factors::{Factor, Rigid, Robust, Var, VarKind};
use speleo_slam::graph_slam::SLAM_LM;
use speleo_slam::lie::Pose;
use speleo_slam::solver::{LmParams, Solver};

const KEYFRAMES: usize = 540;
const SUBMAP: usize = 5;

/// Bias first, then keyframes; the true path goes out along x and back.
fn graph(window: usize) -> (Vec<Var>, Vec<Factor>) {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let half = KEYFRAMES / 2;
    let truth = |k: usize| {
        let x = if k < half { k } else { KEYFRAMES - k } as f64;
        Pose::new(
            Matrix3::identity(),
            Vector3::new(x, 0.1 * (k % 7) as f64, 0.0),
        )
    };
    let mut noisy = |p: Pose| {
        let t = Vector3::new(
            rng.random_range(-0.05..0.05),
            rng.random_range(-0.05..0.05),
            0.0,
        );
        let w = Vector3::new(0.0, 0.0, rng.random_range(-0.01..0.01));
        p.retract(&t, &w)
    };
    let mut vars = vec![Var {
        pose: Pose::identity(),
        kind: VarKind::Tilt,
        fixed: false,
        rigid: None,
    }];
    let mut factors = vec![Factor::RotationPrior {
        i: 0,
        r: Matrix3::identity(),
        sqrt_weight: 57.0,
    }];
    let info = Matrix6::identity() * 30.0;
    for k in 0..KEYFRAMES {
        vars.push(Var {
            pose: noisy(truth(k)),
            kind: VarKind::Pose3,
            fixed: false,
            rigid: None,
        });
        if k + window < KEYFRAMES && k % SUBMAP != 0 {
            let root = k - k % SUBMAP + 1;
            let offset = vars[root].pose.between(&vars[k + 1].pose);
            vars[k + 1].rigid = Some(Rigid {
                parent: root,
                offset,
            });
        }
        let v = k + 1;
        factors.push(Factor::Inclination {
            pose: v,
            bias: 0,
            up: Vector3::z(),
            sqrt_weight: 57.0,
        });
        if k == 0 {
            factors.push(Factor::Anchor {
                i: v,
                position: Vector3::zeros(),
                yaw: 0.0,
                sqrt_weight: 1e3,
            });
        }
        let between = |a: usize, factors: &mut Vec<Factor>| {
            factors.push(Factor::Between {
                i: a + 1,
                j: v,
                z: truth(a).between(&truth(k)),
                sqrt_info: info,
                robust: Robust::Cauchy(3.0),
            });
        };
        for back in 1..=3 {
            if k >= back {
                between(k - back, &mut factors);
            }
        }
        if k > half + 2 {
            between(KEYFRAMES - k, &mut factors);
        }
    }
    (vars, factors)
}

/// As the SLAM back end runs it: Gauss-Newton steps, one factorisation a call.
const LM: LmParams = SLAM_LM;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("pose_graph_window");
    for window in [100, KEYFRAMES] {
        let (vars, factors) = graph(window);
        g.bench_with_input(BenchmarkId::new("analyse", window), &window, |b, _| {
            b.iter(|| Solver::new(&vars, &factors, LM).map(|s| s.unknowns()))
        });
        g.bench_with_input(BenchmarkId::new("lm_iteration", window), &window, |b, _| {
            let mut solver = Solver::new(&vars, &factors, LM).unwrap_or_else(|e| panic!("{e}"));
            b.iter_batched_ref(
                || vars.clone(),
                |v| {
                    solver.reset();
                    solver.iterate(v, &factors)
                },
                criterion::BatchSize::LargeInput,
            )
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
