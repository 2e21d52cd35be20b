//! The back end on synthetic graphs: a drive out and back with noisy
//! odometry, true loop closures, inclination factors through a bias, and a
//! wrong loop closure that the robust kernel must keep from moving the map.

use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use speleo_slam::factors::{Factor, Robust, Var, VarKind};
use speleo_slam::lie::{exp_so3, Pose};
use speleo_slam::solver::{LmParams, Solver};

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    // Box-Muller from two uniforms.
    let u: f64 = rng.random::<f64>().max(1e-12);
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

/// 60 poses 1 m apart out along a gently turning, climbing path and back.
fn truth() -> Vec<Pose> {
    let mut poses = Vec::new();
    let mut p = Pose::identity();
    for k in 0..60 {
        poses.push(p);
        let turn = if k == 29 { std::f64::consts::PI } else { 0.03 };
        let step = Pose::new(
            exp_so3(&Vector3::new(0.0, 0.01, turn)),
            Vector3::new(1.0, 0.0, 0.02),
        );
        p = p.compose(&step);
    }
    poses
}

struct Built {
    vars: Vec<Var>,
    factors: Vec<Factor>,
}

fn build(truth: &[Pose], bias: &Matrix3<f64>, rng: &mut ChaCha8Rng, wrong_loop: bool) -> Built {
    let sigma_t = 0.05;
    let sigma_r = 0.01;
    let u = Matrix6::from_diagonal(&Vector6::new(
        1.0 / sigma_t,
        1.0 / sigma_t,
        1.0 / sigma_t,
        1.0 / sigma_r,
        1.0 / sigma_r,
        1.0 / sigma_r,
    ));
    let mut vars = vec![Var {
        pose: Pose::identity(),
        kind: VarKind::Tilt,
        fixed: false,
        rigid: None,
    }];
    let mut factors = vec![Factor::Anchor {
        i: 1,
        position: truth[0].t,
        yaw: truth[0].yaw(),
        sqrt_weight: 1e3,
    }];
    let mut dead = truth[0];
    for (k, x) in truth.iter().enumerate() {
        if k > 0 {
            let z_true = truth[k - 1].between(x);
            let noise = Pose::new(
                exp_so3(&(Vector3::new(gauss(rng), gauss(rng), gauss(rng)) * sigma_r)),
                Vector3::new(gauss(rng), gauss(rng), gauss(rng)) * sigma_t,
            );
            let z = z_true.compose(&noise);
            dead = dead.compose(&z);
            factors.push(Factor::Between {
                i: k,
                j: k + 1,
                z,
                sqrt_info: u,
                robust: Robust::None,
            });
        }
        vars.push(Var {
            pose: dead,
            kind: VarKind::Pose3,
            fixed: false,
            rigid: None,
        });
        // The IMU sees gravity through the bias.
        let up = bias.transpose() * x.r.transpose() * Vector3::z();
        factors.push(Factor::Inclination {
            pose: k + 1,
            bias: 0,
            up,
            sqrt_weight: 1.0 / 0.2f64.to_radians(),
        });
    }
    // Loop closures: pose k on the way out against 59 - k on the way back.
    for k in (2..28).step_by(5) {
        let j = 59 - k;
        factors.push(Factor::Between {
            i: k + 1,
            j: j + 1,
            z: truth[k].between(&truth[j]),
            sqrt_info: u,
            robust: Robust::Cauchy(10.0),
        });
    }
    if wrong_loop {
        // Claims pose 10 is where pose 45 is, 4 m off.
        factors.push(Factor::Between {
            i: 11,
            j: 46,
            z: Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, 0.0)),
            sqrt_info: u,
            robust: Robust::Cauchy(10.0),
        });
    }
    Built { vars, factors }
}

fn solve(mut b: Built) -> Vec<Var> {
    let mut s = Solver::new(&b.vars, &b.factors, LmParams::default()).expect("solver");
    s.solve(&mut b.vars, &b.factors, 100);
    b.vars
}

fn errors(vars: &[Var], truth: &[Pose]) -> (f64, f64) {
    let e: Vec<f64> = truth
        .iter()
        .enumerate()
        .map(|(k, x)| (vars[k + 1].pose.t - x.t).norm())
        .collect();
    (
        e.iter().sum::<f64>() / e.len() as f64,
        e.iter().fold(0.0, |m: f64, v| m.max(*v)),
    )
}

#[test]
fn loop_closures_and_inclination_bring_the_drive_back_and_find_the_bias() {
    let t = truth();
    let bias = exp_so3(&Vector3::new(2f64.to_radians(), -1f64.to_radians(), 0.0));
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let b = build(&t, &bias, &mut rng, false);
    let (dead_mean, _) = errors(&b.vars, &t);
    let vars = solve(b);
    let (mean, _) = errors(&vars, &t);
    // The way out keeps its open-loop drift (nothing observes it); the way
    // back is pulled onto it.
    assert!(
        mean < dead_mean / 2.0,
        "dead reckoning {dead_mean}, optimised {mean}"
    );
    for k in (2..28).step_by(5) {
        let j = 59 - k;
        let est = vars[k + 1].pose.between(&vars[j + 1].pose);
        let tru = t[k].between(&t[j]);
        assert!(
            (est.t - tru.t).norm() < 0.1,
            "closure {k}-{j}: {}",
            (est.t - tru.t).norm()
        );
    }
    let up_est = vars[0].pose.r.transpose() * Vector3::z();
    let up_true = bias.transpose() * Vector3::z();
    let err = up_est.angle(&up_true).to_degrees();
    assert!(err < 0.2, "bias tilt error {err} deg");
}

#[test]
fn a_wrong_loop_closure_does_not_move_the_map_beyond_the_noise() {
    let t = truth();
    let bias = Matrix3::identity();
    let good = solve(build(&t, &bias, &mut ChaCha8Rng::seed_from_u64(3), false));
    let bad = solve(build(&t, &bias, &mut ChaCha8Rng::seed_from_u64(3), true));
    let (good_mean, _) = errors(&good, &t);
    let moved = good
        .iter()
        .zip(&bad)
        .skip(1)
        .map(|(a, b)| (a.pose.t - b.pose.t).norm())
        .fold(0.0, f64::max);
    // The odometry noise is 5 cm a step; the wrong closure claims 4 m.
    assert!(
        moved < 0.1,
        "the wrong closure moved the map by {moved} m (error without it {good_mean})"
    );
}

#[test]
fn factors_between_frozen_poses_cost_nothing_and_change_nothing() {
    let t = truth();
    let bias = Matrix3::identity();
    let frozen = |mut b: Built| {
        // The first 20 poses are frozen, as a sliding window leaves them.
        for v in b.vars.iter_mut().skip(1).take(20) {
            v.fixed = true;
        }
        b
    };
    let plain = solve(frozen(build(
        &t,
        &bias,
        &mut ChaCha8Rng::seed_from_u64(5),
        false,
    )));
    let mut b = frozen(build(&t, &bias, &mut ChaCha8Rng::seed_from_u64(5), false));
    // A nonsense factor among frozen poses only: the solver must leave it out
    // of the system and of the cost comparisons.
    b.factors.push(Factor::Between {
        i: 3,
        j: 15,
        z: Pose::new(Matrix3::identity(), Vector3::new(40.0, -3.0, 7.0)),
        sqrt_info: Matrix6::identity() * 100.0,
        robust: Robust::None,
    });
    let with = solve(b);
    for (a, b) in plain.iter().zip(&with) {
        assert_eq!(a.pose.t, b.pose.t);
        assert_eq!(a.pose.r, b.pose.r);
    }
}
