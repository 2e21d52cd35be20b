//! GICP registration: known transforms on synthetic rooms, the Hessian's
//! parametrisation against numeric differences of the cost, the kd-tree
//! against brute force, determinism, bounded memory (no allocation once
//! built), bad input, and consistency on a real HDL-32E pair from
//! ../shared/data (skipped, with a message, when absent).

use nalgebra::{Isometry3, Matrix6, Translation3, UnitQuaternion, Vector3, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use speleo_scheduler::accounting::{allocations_in, AccountingAllocator};
use speleo_slam::registration::{
    align, cost, perturb, Aligner, Alignment, GicpParams, KdTree, Kernel, Neighbor, PreparedCloud,
    VoxelGrid,
};

// Allocations are counted per thread: tests run in parallel.
#[global_allocator]
static A: AccountingAllocator = AccountingAllocator;

// ---- Synthetic scenes ----

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    // Box-Muller.
    let u: f64 = rng.random::<f64>().max(1e-300);
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// Axis-aligned boxes `(lo, hi)` whose surfaces make a room: walls, floor,
/// ceiling, two pillars and a step, so every direction is constrained.
const ROOM: [([f64; 3], [f64; 3]); 4] = [
    ([-6.0, -4.0, -1.0], [6.0, 4.0, 2.0]),
    ([1.0, 1.0, -1.0], [1.6, 1.8, 2.0]),
    ([-3.0, -2.5, -1.0], [-2.2, -1.0, 2.0]),
    ([-1.0, 2.0, -1.0], [3.0, 4.0, -0.5]),
];

/// `n` points sampled uniformly on the room's surfaces, with Gaussian noise
/// of `sigma` metres.
fn room(n: usize, sigma: f64, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut faces = Vec::new();
    for (lo, hi) in ROOM {
        for axis in 0..3 {
            for side in [lo[axis], hi[axis]] {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let area = (hi[u] - lo[u]) * (hi[v] - lo[v]);
                faces.push((axis, side, lo, hi, u, v, area));
            }
        }
    }
    let total: f64 = faces.iter().map(|f| f.6).sum();
    let mut out = Vec::with_capacity(n);
    for f in &faces {
        let m = ((f.6 / total) * n as f64).round() as usize;
        for _ in 0..m {
            let mut p = [0.0; 3];
            p[f.0] = f.1;
            p[f.4] = f.2[f.4] + rng.random::<f64>() * (f.3[f.4] - f.2[f.4]);
            p[f.5] = f.2[f.5] + rng.random::<f64>() * (f.3[f.5] - f.2[f.5]);
            for x in &mut p {
                *x += sigma * gauss(&mut rng);
            }
            out.push(p);
        }
    }
    out
}

fn iso(t: [f64; 3], rpy_deg: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(t[0], t[1], t[2]),
        UnitQuaternion::from_euler_angles(
            rpy_deg[0].to_radians(),
            rpy_deg[1].to_radians(),
            rpy_deg[2].to_radians(),
        ),
    )
}

fn apply(tf: &Isometry3<f64>, pts: &[[f64; 3]]) -> Vec<[f64; 3]> {
    pts.iter()
        .map(|p| {
            let q = tf * nalgebra::Point3::new(p[0], p[1], p[2]);
            [q.x, q.y, q.z]
        })
        .collect()
}

/// (rotation error in degrees, translation error in metres) of `a` vs `b`.
fn error(a: &Isometry3<f64>, b: &Isometry3<f64>) -> (f64, f64) {
    let d = a.inverse() * b;
    (
        d.rotation.angle().to_degrees(),
        (a.translation.vector - b.translation.vector).norm(),
    )
}

fn prepared(pts: &[[f64; 3]], voxel: f64) -> PreparedCloud {
    let mut c = PreparedCloud::with_capacity(pts.len().max(1));
    c.prepare(pts.iter().copied(), voxel);
    c
}

// ---- GICP ----

#[test]
fn recovers_known_transforms_in_a_room() {
    let target = prepared(&room(30_000, 0.005, 1), 0.1);
    let world_b = room(30_000, 0.005, 2);
    for (k, truth) in [
        iso([0.5, 0.0, 0.0], [0.0, 0.0, 10.0]),
        iso([-0.3, 0.4, 0.1], [2.0, -3.0, -8.0]),
        iso([0.2, -0.45, -0.1], [-4.0, 1.5, 5.0]),
        iso([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
        iso([0.35, 0.35, 0.05], [1.0, 1.0, 9.0]),
    ]
    .iter()
    .enumerate()
    {
        // Source frame S with target <- S = truth: its points are
        // truth^-1 applied to a second, independent sample of the room.
        let source = prepared(&apply(&truth.inverse(), &world_b), 0.1);
        for kernel in [
            Kernel::None,
            Kernel::Huber { delta: 1.0 },
            Kernel::GemanMcClure { c: 2.0 },
        ] {
            let params = GicpParams {
                kernel,
                ..GicpParams::default()
            };
            let a = align(&source, &target, &Isometry3::identity(), &params);
            let (dr, dt) = error(&a.transform, truth);
            eprintln!(
                "case {k} {kernel:?}: {dr:.5} deg, {:.3} mm, {} iterations, fitness {:.4}",
                dt * 1e3,
                a.iterations,
                a.fitness
            );
            assert!(a.converged, "case {k} {kernel:?}: {a:?}");
            assert!(
                dr < 0.01 && dt < 0.001,
                "case {k} {kernel:?}: {dr} deg, {dt} m"
            );
            assert!(a.inlier_fraction > 0.95 && a.fitness < 0.1, "{a:?}");
        }
    }
}

/// Exact copies (no noise, no downsampling): the residuals vanish at the
/// true transform, so the Gauss-Newton Hessian equals the cost's second
/// derivative there. A large rotation and a cloud far from the origin make
/// any other parametrisation (translation in the target frame, left
/// perturbation, rotation first) fail by a wide margin.
#[test]
fn hessian_is_the_cost_curvature_in_the_documented_parametrisation() {
    let world = apply(
        &iso([20.0, -7.0, 3.0], [0.0, 0.0, 0.0]),
        &room(4_000, 0.0, 3),
    );
    let truth = iso([1.5, -0.8, 0.4], [10.0, -25.0, 40.0]);
    let target = prepared(&world, 0.0);
    let source = prepared(&apply(&truth.inverse(), &world), 0.0);
    let params = GicpParams {
        max_iterations: 1,
        ..GicpParams::default()
    };
    let at_truth = align(&source, &target, &truth, &params);
    let h = at_truth.hessian;
    let f = |d: &Vector6<f64>| cost(&source, &target, &perturb(&truth, d), &params).0;
    let step = 1e-4;
    let mut num = Matrix6::zeros();
    for i in 0..6 {
        for j in 0..6 {
            let e = |k: usize, s: f64| {
                let mut v = Vector6::zeros();
                v[k] = s;
                v
            };
            num[(i, j)] = (f(&(e(i, step) + e(j, step)))
                - f(&(e(i, step) + e(j, -step)))
                - f(&(e(i, -step) + e(j, step)))
                + f(&(e(i, -step) + e(j, -step))))
                / (4.0 * step * step);
        }
    }
    let rel = (num - h).norm() / h.norm();
    assert!(
        rel < 1e-4,
        "relative difference {rel}\nnumeric {num}\nreported {h}"
    );
    // The same Hessian comes back from a full alignment started elsewhere.
    let full = align(
        &source,
        &target,
        &(truth * iso([0.3, -0.2, 0.1], [3.0, -2.0, 4.0])),
        &GicpParams::default(),
    );
    assert!(full.converged);
    let rel = (full.hessian - h).norm() / h.norm();
    assert!(rel < 1e-3, "{rel}");
}

/// On noisy data the solution solves the Gauss-Newton normal equations:
/// the gradient, in the perturbation coordinates, of the cost with the
/// correspondences and the weights frozen at the solution is zero. (The
/// full cost also varies through the weights' `R C_s R^T`; like other GICP
/// implementations the solver holds them constant within an iteration, so
/// only this frozen form is exactly stationary.)
#[test]
fn solution_solves_the_normal_equations() {
    let target = prepared(&room(20_000, 0.01, 4), 0.1);
    let truth = iso([0.3, 0.1, -0.05], [1.0, -2.0, 6.0]);
    let source = prepared(&apply(&truth.inverse(), &room(20_000, 0.01, 5)), 0.1);
    let params = GicpParams {
        translation_eps_m: 1e-10,
        rotation_eps_rad: 1e-10,
        max_iterations: 60,
        ..GicpParams::default()
    };
    let a = align(&source, &target, &Isometry3::identity(), &params);
    assert!(a.converged, "{a:?}");
    // Correspondences and weights at the solution, from the public data;
    // the weights are frozen in the target frame, M = (C_t + R C_s R^T)^-1,
    // as the solver freezes them within an iteration.
    let tf = a.transform;
    let rm = *tf.rotation.to_rotation_matrix().matrix();
    let max = params.max_correspondence_m * params.max_correspondence_m;
    let mut terms = Vec::new();
    for (p, cs) in source.points().iter().zip(source.covariances()) {
        let pv = Vector3::new(p[0], p[1], p[2]);
        let x = tf * nalgebra::Point3::from(pv);
        if let Some(nn) = target.tree().nearest(&[x.x, x.y, x.z], max) {
            let j = nn.index as usize;
            let q = target.points()[j];
            let m = (target.covariances()[j] + rm * cs * rm.transpose())
                .try_inverse()
                .expect("invertible");
            terms.push((pv, Vector3::new(q[0], q[1], q[2]), m));
        }
    }
    assert_eq!(terms.len(), a.inliers);
    let frozen = |d: &Vector6<f64>| -> f64 {
        let t = perturb(&tf, d);
        terms
            .iter()
            .map(|(p, q, m)| {
                let r = (t * nalgebra::Point3::from(*p)).coords - q;
                0.5 * r.dot(&(m * r))
            })
            .sum()
    };
    let step = 1e-6;
    let mut g = Vector6::zeros();
    for i in 0..6 {
        let mut d = Vector6::zeros();
        d[i] = step;
        g[i] = (frozen(&d) - frozen(&(-d))) / (2.0 * step);
    }
    let newton = a.hessian.cholesky().expect("positive definite").solve(&g);
    assert!(newton.norm() < 1e-7, "remaining step {newton}");
}

fn bits(x: &Alignment) -> Vec<u64> {
    let m = x.transform.to_homogeneous();
    let mut v: Vec<u64> = m
        .iter()
        .chain(x.hessian.iter())
        .map(|f| f.to_bits())
        .collect();
    v.extend([x.fitness.to_bits(), x.inliers as u64, x.iterations as u64]);
    v
}

#[test]
fn work_cut_into_bounded_parts_gives_the_same_bits() {
    let pts_t = room(15_000, 0.01, 16);
    let pts_s = apply(
        &iso([0.3, -0.1, 0.05], [1.0, -0.5, 4.0]),
        &room(15_000, 0.01, 17),
    );
    let whole_t = prepared(&pts_t, 0.15);
    let whole_s = prepared(&pts_s, 0.15);
    let params = GicpParams::default();
    let whole = align(&whole_s, &whole_t, &Isometry3::identity(), &params);
    // The same work in parts of 997 points.
    let parts = |pts: &[[f64; 3]]| {
        let mut c = PreparedCloud::with_capacity(pts.len());
        c.begin(0.15);
        for chunk in pts.chunks(997) {
            c.add(chunk.iter().copied());
        }
        c.build();
        let mut units = 1;
        while !c.estimate_covariances(997) {
            units += 1;
        }
        assert!(c.is_ready());
        assert!(units > 1, "the covariances took several parts");
        c
    };
    let (t, s) = (parts(&pts_t), parts(&pts_s));
    assert_eq!(t.points(), whole_t.points());
    assert_eq!(t.covariances(), whole_t.covariances());
    let mut a = Aligner::new(&Isometry3::identity());
    let mut steps = 1;
    while !a.step(&s, &t, &params, 997) {
        steps += 1;
    }
    assert!(steps > whole.iterations as usize, "{steps} steps");
    assert_eq!(bits(&a.result()), bits(&whole));
}

#[test]
fn same_input_gives_bit_identical_results() {
    let pts_t = room(15_000, 0.01, 6);
    let pts_s = apply(
        &iso([0.2, 0.1, 0.0], [0.0, 0.0, 5.0]),
        &room(15_000, 0.01, 7),
    );
    let run = |t: &mut PreparedCloud, s: &mut PreparedCloud| -> Alignment {
        t.prepare(pts_t.iter().copied(), 0.15);
        s.prepare(pts_s.iter().copied(), 0.15);
        align(s, t, &Isometry3::identity(), &GicpParams::default())
    };
    let (mut t1, mut s1) = (
        PreparedCloud::with_capacity(20_000),
        PreparedCloud::with_capacity(20_000),
    );
    let a = run(&mut t1, &mut s1);
    // Reused buffers, then fresh ones.
    let b = run(&mut t1, &mut s1);
    let (mut t2, mut s2) = (
        PreparedCloud::with_capacity(20_000),
        PreparedCloud::with_capacity(20_000),
    );
    let c = run(&mut t2, &mut s2);
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(bits(&a), bits(&c));
}

#[test]
fn prepare_and_align_allocate_nothing() {
    let pts_t = room(15_000, 0.01, 8);
    let pts_s = apply(
        &iso([0.2, 0.1, 0.0], [0.0, 0.0, 5.0]),
        &room(15_000, 0.01, 9),
    );
    let mut t = PreparedCloud::with_capacity(20_000);
    let mut s = PreparedCloud::with_capacity(20_000);
    let (a, n) = allocations_in(|| {
        t.prepare(pts_t.iter().copied(), 0.1);
        s.prepare(pts_s.iter().copied(), 0.1);
        align(&s, &t, &Isometry3::identity(), &GicpParams::default())
    });
    assert!(a.converged);
    assert_eq!(n, 0, "allocations in prepare + align");
}

#[test]
fn capacity_overflow_is_counted_not_grown() {
    let pts = room(10_000, 0.0, 10);
    let mut c = PreparedCloud::with_capacity(500);
    let st = c.prepare(pts.iter().copied(), 0.05);
    assert_eq!(st.points, 500);
    assert_eq!(c.capacity(), 500);
    assert!(st.voxel.over_capacity > 0);
    assert_eq!(st.voxel.input, pts.len());
    // Without downsampling every point beyond 500 is counted.
    let st = c.prepare(pts.iter().copied(), 0.0);
    assert_eq!((st.points, st.voxel.over_capacity), (500, pts.len() - 500));
}

#[test]
fn bad_and_degenerate_input_does_not_panic() {
    let params = GicpParams::default();
    let room_pts = room(5_000, 0.01, 11);
    let good = prepared(&room_pts, 0.1);
    let empty = prepared(&[], 0.1);
    assert!(empty.is_empty());
    for (s, t) in [(&empty, &good), (&good, &empty), (&empty, &empty)] {
        let a = align(s, t, &Isometry3::identity(), &params);
        assert!(!a.converged && a.inliers == 0 && a.iterations == 0);
        assert_eq!(a.transform, Isometry3::identity());
    }
    // Points on a line: rank-deficient, unconstrained along and about it.
    let line: Vec<[f64; 3]> = (0..1000).map(|i| [i as f64 * 0.01, 0.0, 0.0]).collect();
    let l = prepared(&line, 0.05);
    let a = align(&l, &l, &iso([0.01, 0.0, 0.0], [0.0, 0.0, 1.0]), &params);
    assert!(a.transform.translation.vector.iter().all(|v| v.is_finite()));
    // One point, two points, a repeated point.
    for pts in [
        vec![[1.0, 2.0, 3.0]],
        vec![[0.0; 3], [1.0, 0.0, 0.0]],
        vec![[5.0; 3]; 100],
    ] {
        let c = prepared(&pts, 0.1);
        let _ = align(&c, &good, &Isometry3::identity(), &params);
        let _ = align(&good, &c, &Isometry3::identity(), &params);
        let _ = align(&c, &c, &Isometry3::identity(), &params);
    }
    // NaN and infinite points are dropped; far ones too.
    let mut dirty = room_pts.clone();
    dirty.extend([
        [f64::NAN, 0.0, 0.0],
        [0.0, f64::INFINITY, 0.0],
        [1e300, 0.0, 0.0],
    ]);
    let mut c = PreparedCloud::with_capacity(dirty.len());
    let st = c.prepare(dirty.iter().copied(), 0.1);
    assert_eq!((st.voxel.non_finite, st.voxel.out_of_range), (2, 1));
    assert!(c.points().iter().flatten().all(|v| v.is_finite()));
    let a = align(&c, &good, &Isometry3::identity(), &params);
    assert!(a.converged);
    // Nonsense parameters.
    for p in [
        GicpParams {
            max_correspondence_m: f64::NAN,
            ..params
        },
        GicpParams {
            max_correspondence_m: -1.0,
            ..params
        },
        GicpParams {
            max_iterations: 0,
            ..params
        },
        GicpParams {
            damping: f64::NAN,
            ..params
        },
        GicpParams {
            kernel: Kernel::Huber { delta: f64::NAN },
            ..params
        },
    ] {
        let a = align(&good, &good, &Isometry3::identity(), &p);
        assert!(
            !a.converged || a.transform == Isometry3::identity(),
            "{p:?}: {a:?}"
        );
    }
    // A non-finite initial guess.
    let mut bad = Isometry3::identity();
    bad.translation.vector.x = f64::NAN;
    let a = align(&good, &good, &bad, &params);
    assert!(!a.converged);
}

// ---- Voxel grid and kd-tree ----

#[test]
fn voxel_grid_keeps_one_centroid_per_voxel() {
    // A 10 x 10 x 10 lattice of 8-point clusters, one cluster per 1 m voxel.
    let mut pts = Vec::new();
    for i in 0..10 {
        for j in 0..10 {
            for k in 0..10 {
                for c in 0..8 {
                    let o = [(c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64];
                    pts.push([
                        i as f64 + 0.3 + 0.2 * o[0],
                        j as f64 + 0.3 + 0.2 * o[1],
                        -(k as f64) - 0.3 - 0.2 * o[2],
                    ]);
                }
            }
        }
    }
    let mut g = VoxelGrid::with_capacity(2000);
    let st = g.downsample(pts.iter().copied(), 1.0);
    assert_eq!(st.output, 1000);
    for p in g.points() {
        for (x, sign) in p.iter().zip([1.0, 1.0, -1.0]) {
            let f = (x * sign).fract();
            assert!((f - 0.4).abs() < 1e-9, "{p:?}");
        }
    }
}

#[test]
fn kdtree_matches_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let pts: Vec<[f64; 3]> = (0..3000)
        .map(|_| {
            [
                rng.random::<f64>() * 20.0 - 10.0,
                rng.random::<f64>() * 8.0,
                rng.random::<f64>() * 2.0,
            ]
        })
        .chain((0..200).map(|i| [1.0, 1.0, (i % 10) as f64 * 0.1])) // duplicates
        .collect();
    for leaf in [1, 4, 8, 32] {
        let mut t = KdTree::with_capacity_and_leaf_size(pts.len(), leaf);
        t.build(&pts);
        assert_eq!(t.len(), pts.len());
        for (i, p) in t.points().iter().enumerate() {
            assert_eq!(*p, pts[t.input_index(i).expect("index")]);
        }
        let mut out = [Neighbor {
            index: 0,
            dist_sq: 0.0,
        }; 12];
        for q in 0..300 {
            let q = [
                rng.random::<f64>() * 24.0 - 12.0,
                rng.random::<f64>() * 10.0 - 1.0,
                if q % 3 == 0 {
                    1.0
                } else {
                    rng.random::<f64>() * 3.0 - 0.5
                },
            ];
            let mut brute: Vec<f64> = pts
                .iter()
                .map(|p| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2))
                .collect();
            brute.sort_by(f64::total_cmp);
            for k in [1, 5, 10, 12] {
                let n = t.knn(&q, f64::INFINITY, &mut out[..k]);
                assert_eq!(n, k);
                for (m, nb) in out[..k].iter().enumerate() {
                    assert_eq!(nb.dist_sq, brute[m], "leaf {leaf} k {k}");
                    let p = t.points()[nb.index as usize];
                    let d = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2);
                    assert_eq!(d, nb.dist_sq);
                }
            }
            // Radius-bounded queries.
            for r2 in [0.01, 0.5, 4.0] {
                let within = brute.iter().take_while(|d| **d <= r2).count();
                let n = t.knn(&q, r2, &mut out[..10]);
                assert_eq!(n, within.min(10));
                match t.nearest(&q, r2) {
                    Some(nb) => assert_eq!(nb.dist_sq, brute[0]),
                    None => assert!(brute[0] > r2),
                }
            }
        }
    }
}

// ---- Real data: an HDL-32E pair ----

fn hdl32e_frames() -> Option<Vec<Vec<[f64; 3]>>> {
    use speleo_hal::hdl32e::{Calibration, DataPacket, Decoder, FrameAssembler, DATA_PORT};
    let pcap = speleo_hal::shared_data::path("velodyne/monterey-first-100-packets.pcap")?;
    let (dgrams, _) = speleo_hal::pcap::read_udp(&pcap).expect("capture reads");
    let mut asm = FrameAssembler::new(Decoder::new(&Calibration::nominal()), 0.0, 200_000);
    let mut frames = Vec::new();
    let to_f64 = |f: &speleo_hal::hdl32e::frames::Frame<'_>| -> Vec<[f64; 3]> {
        f.points
            .iter()
            .map(|p| [p.x as f64, p.y as f64, p.z as f64])
            .collect()
    };
    for d in dgrams.iter().filter(|d| d.dst.port() == DATA_PORT) {
        if let Ok(p) = DataPacket::parse(&d.payload) {
            asm.push(&p, |f| frames.push(to_f64(f)));
        }
    }
    Some(frames)
}

/// small_gicp 1.0.1 (PyPI), `align(target=frame 9, source=frame 8,
/// downsampling_resolution=0.25, num_threads=1, registration_type='GICP')`
/// with its other defaults, on this decoder's frames (nominal calibration,
/// cut at 0 deg): `T_target_source`, rows 0-2.
const SMALL_GICP_PAIR: [[f64; 4]; 3] = [
    [
        9.9999997861e-01,
        -1.7969756511e-04,
        1.0242110659e-04,
        1.9256574868e-04,
    ],
    [
        1.7969766250e-04,
        9.9999998385e-01,
        -9.4167204268e-07,
        1.3633100735e-03,
    ],
    [
        -1.0242093572e-04,
        9.6007685598e-07,
        9.9999999475e-01,
        3.9297856715e-04,
    ],
];
/// The same with frame 8 moved by `K` (5 deg yaw, 1 deg roll, then
/// (0.5, 0.2, 0.05) m) before registration.
const SMALL_GICP_PERTURBED: [[f64; 4]; 3] = [
    [
        9.9621085003e-01,
        8.6970844727e-02,
        1.2016949108e-04,
        -5.1273990288e-01,
    ],
    [
        -8.6959707945e-02,
        9.9605918814e-01,
        1.7438547123e-02,
        -1.5533183948e-01,
    ],
    [
        1.3969492484e-03,
        -1.7382919757e-02,
        9.9984792975e-01,
        -4.6795433419e-02,
    ],
];

/// (rotation difference in degrees, translation difference in metres)
/// between `a` and the 3x4 matrix `b`.
fn error_to(a: &Isometry3<f64>, b: &[[f64; 4]; 3]) -> (f64, f64) {
    let m = a.to_homogeneous();
    let (mut fro, mut dt) = (0.0, 0.0);
    for (r, row) in b.iter().enumerate() {
        for c in 0..3 {
            fro += (m[(r, c)] - row[c]).powi(2);
        }
        dt += (m[(r, 3)] - row[3]).powi(2);
    }
    // For a small rotation between them, |Ra - Rb|_F = sqrt(2) * angle.
    ((fro / 2.0).sqrt().to_degrees(), dt.sqrt())
}

/// No ground truth exists for consecutive real frames, so two checks:
/// consistency (moving the source frame by a known transform K must move
/// the result by exactly K^-1, within what downsampling a moved cloud
/// changes) and agreement with small_gicp on the same pairs.
#[test]
fn real_hdl32e_pair_is_consistent_and_agrees_with_small_gicp() {
    let Some(frames) = hdl32e_frames() else {
        eprintln!("skipped: real HDL-32E pair (no shared data)");
        return;
    };
    let (src, tgt) = (&frames[8], &frames[9]);
    assert!(src.len() > 45_000 && tgt.len() > 45_000);
    let voxel = 0.25;
    let params = GicpParams::default();
    let mut target = PreparedCloud::with_capacity(80_000);
    let mut source = PreparedCloud::with_capacity(80_000);
    target.prepare(tgt.iter().copied(), voxel);
    source.prepare(src.iter().copied(), voxel);
    let a = align(&source, &target, &Isometry3::identity(), &params);
    assert!(a.converged && a.inlier_fraction > 0.9, "{a:?}");
    let k = iso([0.5, 0.2, 0.05], [1.0, 0.0, 5.0]);
    source.prepare(apply(&k, src), voxel);
    let b = align(&source, &target, &Isometry3::identity(), &params);
    assert!(b.converged, "{b:?}");
    let (dr, dt) = error(&b.transform, &(a.transform * k.inverse()));
    let (sr, st) = error_to(&a.transform, &SMALL_GICP_PAIR);
    let (skr, skt) = error_to(&b.transform, &SMALL_GICP_PERTURBED);
    eprintln!(
        "real pair: {} + {} points after downsampling, {} and {} iterations, fitness {:.4} m, \
         inliers {:.3}; consistency {dr:.4} deg, {:.2} mm; vs small_gicp {sr:.6} deg, \
         {:.4} mm and {skr:.6} deg, {:.4} mm",
        target.len(),
        source.len(),
        a.iterations,
        b.iterations,
        a.fitness,
        a.inlier_fraction,
        dt * 1e3,
        st * 1e3,
        skt * 1e3,
    );
    assert!(dr < 0.4 && dt < 0.035, "consistency: {dr} deg, {dt} m");
    assert!(sr < 0.01 && st < 0.001, "vs small_gicp: {sr} deg, {st} m");
    assert!(
        skr < 0.01 && skt < 0.001,
        "vs small_gicp: {skr} deg, {skt} m"
    );
}

/// A corridor 4 m wide with a recess in the walls every 3 m (so the axis is
/// constrained, weakly), sampled as a sensor at `(x, 0, 0)` sees it: the
/// surface within `range` metres, in the sensor's frame.
fn corridor_seen_from(x: f64, range: f64, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    while out.len() < 40_000 {
        let px = x + (rng.random::<f64>() * 2.0 - 1.0) * range;
        let u: f64 = rng.random();
        let recess = (px.rem_euclid(3.0)) < 0.6;
        let p = if u < 0.3 {
            [px, rng.random::<f64>() * 4.0 - 2.0, -1.0]
        } else if u < 0.5 {
            [px, rng.random::<f64>() * 4.0 - 2.0, 2.0]
        } else {
            let side = if u < 0.75 { 1.0 } else { -1.0 };
            let depth = if recess { 2.3 } else { 2.0 };
            [px, side * depth, rng.random::<f64>() * 3.0 - 1.0]
        };
        let d = [p[0] - x, p[1], p[2]];
        if d.iter().map(|v| v * v).sum::<f64>().sqrt() <= range {
            out.push([d[0] + 0.003 * gauss(&mut rng), d[1], d[2]]);
        }
    }
    out
}

/// The new scan sees farther down the corridor than the old one: with a
/// wide pairing reach its last points pair with the old scan's last ones,
/// up to the motion back, and the motion comes out short. Refining within
/// a tighter reach (as every on-board registration does) removes most of
/// that; so does keeping only mutual nearest neighbours.
#[test]
fn a_tighter_second_stage_removes_the_coverage_edge_bias() {
    let target = prepared(&corridor_seen_from(0.0, 10.0, 21), 0.2);
    let source = prepared(&corridor_seen_from(1.0, 10.0, 22), 0.2);
    let truth = iso([1.0, 0.0, 0.0], [0.0, 0.0, 0.0]);
    // Odometry that over-reads by 3%, as the leg-wheels do.
    let init = iso([1.03, 0.0, 0.0], [0.0, 0.0, 0.0]);
    let wide = GicpParams {
        max_correspondence_m: 1.0,
        max_iterations: 30,
        ..GicpParams::default()
    };
    let one = align(&source, &target, &init, &wide);
    let tight = GicpParams {
        max_correspondence_m: 0.4,
        ..wide
    };
    let two = align(&source, &target, &one.transform, &tight);
    let mutual = GicpParams {
        mutual: true,
        ..tight
    };
    let three = align(&source, &target, &one.transform, &mutual);
    let along = |a: &Alignment| a.transform.translation.x - truth.translation.x;
    eprintln!(
        "along-axis error: one stage {:.1} mm, two stages {:.1} mm, mutual {:.1} mm",
        along(&one) * 1e3,
        along(&two) * 1e3,
        along(&three) * 1e3
    );
    assert!(
        along(&one) < -0.005,
        "the wide reach alone should read short"
    );
    assert!(
        along(&two).abs() < along(&one).abs() / 2.0,
        "refined {} vs {}",
        along(&two),
        along(&one)
    );
    assert!(
        along(&three).abs() < along(&one).abs() / 2.0 && three.inlier_fraction > 0.8,
        "mutual {} vs {}, {} paired",
        along(&three),
        along(&one),
        three.inlier_fraction
    );
}
