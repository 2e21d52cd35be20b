//! The on-board SLAM pipeline (paper section 2.1): keyframes with their
//! downsampled scans, GICP factors to the nearest keyframes, odometry
//! factors between successive keyframes, inclination factors through the
//! IMU-to-LiDAR bias, loop closures verified by GICP fitness under a robust
//! kernel, and Levenberg-Marquardt run in anytime steps.
//!
//! Work is split into [`GraphSlam::step`]s of bounded size (prepare one
//! cloud, one registration, insert, one LM iteration), so a scheduler can
//! spread a keyframe over several frames; the sequence of steps depends
//! only on the data, never on time. All buffers are sized at construction;
//! only the solver's symbolic analysis allocates when the graph's structure
//! changes (a new keyframe), inside the task's memory budget.

use heapless::Vec as HVec;
use nalgebra::{Matrix3, Matrix6, Vector3};

use crate::factors::{Factor, Rigid, Robust, Var, VarKind};
use crate::lie::Pose;
use crate::registration::degeneracy::keep_guess_where_unheld;
use crate::registration::gicp::{Aligner, Alignment, GicpParams, PreparedCloud};
use crate::solver::{LmParams, Solver, Step};

pub use crate::params::SlamParams;

/// An index stride near `n / golden ratio` that is coprime with `n`, so
/// `i * stride % n` visits every index once, evenly spread.
fn interleave_stride(n: usize) -> usize {
    if n < 3 {
        return 1;
    }
    let gcd = |mut a: usize, mut b: usize| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    let mut s = ((n as f64) * 0.618_033_988_749_895) as usize;
    while gcd(s, n) != 1 {
        s += 1;
    }
    s
}

/// The verification of the latest loop candidate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopCheck {
    pub older: usize,
    pub newer: usize,
    /// GICP's inlier RMSE, m, and the share of points that found a match.
    pub fitness_m: f64,
    pub inlier_fraction: f64,
    pub iterations: u32,
    pub accepted: bool,
    /// The alignment's information along its least constrained direction
    /// of translation (the smallest eigenvalue of the Hessian's
    /// translation block, as the factor weighs it), and that direction:
    /// on a flat, featureless plane the scans slide over each other.
    pub weakest_info: f64,
    pub weakest_axis: [f64; 3],
}

/// A registration that kept the guess along directions its surfaces did
/// not hold (see [`SlamParams::min_surface_share`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unheld {
    /// The keyframe registered to (the new one is the next after the
    /// last), and the number of such directions.
    pub target: usize,
    pub directions: usize,
    /// The smallest share of a direction's information that the normals
    /// carried (see `registration::degeneracy::surface_shares`).
    pub surface_share: f64,
}

/// The smallest eigenvalue of the translation block of `h` and its unit
/// eigenvector.
fn weakest_translation(h: &Matrix6<f64>) -> (f64, [f64; 3]) {
    let t: Matrix3<f64> = h.fixed_view::<3, 3>(0, 0).into_owned();
    let e = t.symmetric_eigen();
    let i = e.eigenvalues.imin();
    let v = e.eigenvectors.column(i);
    (e.eigenvalues[i], [v[0], v[1], v[2]])
}

/// Why a loop closure from outside was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoopClosureError {
    /// A keyframe is being processed; try again when idle.
    Busy,
    NoSuchKeyframes {
        older: usize,
        newer: usize,
        n: usize,
    },
    /// The factor store is full.
    Full,
}

impl std::fmt::Display for LoopClosureError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoopClosureError::Busy => write!(f, "SLAM is processing a keyframe"),
            LoopClosureError::NoSuchKeyframes { older, newer, n } => write!(
                f,
                "a loop closure needs keyframes older < newer < {n}, got {older} and {newer}"
            ),
            LoopClosureError::Full => write!(f, "the factor store is full"),
        }
    }
}

impl std::error::Error for LoopClosureError {}

/// What the pipeline has done.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlamStats {
    pub keyframes: u64,
    /// Keyframes that left the active window for a rigid sub-map.
    pub grouped: u64,
    pub registrations: u64,
    pub registrations_rejected: u64,
    /// Registrations that kept the guess along some direction their
    /// surfaces did not hold (`SlamParams::min_surface_share`).
    pub registrations_unheld: u64,
    pub loop_closures: u64,
    pub loop_candidates_rejected: u64,
    pub lm_iterations: u64,
    /// Scans offered while a keyframe was still being processed.
    pub scans_busy: u64,
    /// Keyframes refused because the store was full.
    pub keyframes_refused: u64,
    pub solver_failures: u64,
    /// Scan points that found the voxel grid full (the keyframe keeps a
    /// spatially even subset of `max_scan_points` voxels).
    pub scan_points_dropped: u64,
    /// Loop closures added from outside (place recognition, fault injection).
    pub external_loop_closures: u64,
}

/// A keyframe's bookkeeping (its scan lives in the shared pool).
#[derive(Clone, Copy, Debug)]
pub struct Keyframe {
    pub stamp_ns: u64,
    /// Odometry pose when the scan started.
    pub odom: Pose,
    /// Gravity "up" in the IMU frame.
    pub up_imu: Vector3<f64>,
    points: usize,
    /// Index of the factor registering it to its predecessor, if accepted.
    registration: Option<usize>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Idle,
    /// Feed the new scan's points from this index into the voxel grid.
    Gather(usize),
    /// Finish the downsampling and build the kd-tree.
    Build,
    Covariances,
    Register(usize),
    Insert,
    /// The solver's structural analysis of the changed graph.
    Analyse,
    /// Levenberg-Marquardt: steps accepted and calls made so far.
    Optimize {
        accepted: u32,
        calls: u32,
    },
}

#[derive(Clone, Copy, Debug)]
struct Candidate {
    keyframe: usize,
    is_loop: bool,
    /// Every candidate is aligned twice: within
    /// `gicp.max_correspondence_m`, then from there within
    /// `refine_distance_m` (`loop_verify_distance_m` for a loop, whose
    /// fitness and overlap then decide).
    refining: bool,
    result: Option<Alignment>,
    /// Some direction kept the guess (see `keep_guess_where_unheld`).
    unheld: bool,
}

const MAX_CANDIDATES: usize = 8;
/// The on-board solver settings: the pose graph has no chordal factors
/// (nothing for Newton steps), and one factorisation per call keeps every
/// step within its time.
pub const SLAM_LM: LmParams = LmParams {
    initial_lambda: 1e-12,
    relative_tolerance: 1e-5,
    step_tolerance: 1e-10,
    refinement_steps: 2,
    newton: false,
    attempts_per_iteration: 1,
};

/// Variable index of the bias; keyframe `k` is variable `k + 1`.
const BIAS: usize = 0;

/// The odometry's distance scale, learned from the registrations to the
/// previous keyframe. Leg-wheels over-read by a few percent (their rolling
/// radius changes with the legs' angle, the load and the ground), and the
/// odometry moves every point of a revolution in the deskewing and predicts
/// where a new keyframe is: an over-read shears each scan by the
/// over-read share of the 4 cm driven per revolution, and the shear differs
/// between two scans of the same wall seen from different places.
#[derive(Clone, Copy, Debug, Default)]
struct OdometryScale {
    /// Decaying sums of registered and odometry distances.
    registered: f64,
    odometry: f64,
}

impl OdometryScale {
    /// Each keyframe weighs this much of the one before (about the last
    /// 20 keyframes count).
    const MEMORY: f64 = 0.95;
    /// Odometry distance (decayed) before the scale is trusted.
    const MIN_DISTANCE_M: f64 = 3.0;
    /// Ratios beyond these are not slip but a stuck rover or a bad match.
    const RANGE: (f64, f64) = (0.7, 1.3);

    fn add(&mut self, registered_m: f64, odometry_m: f64) {
        if odometry_m < 0.3 {
            return;
        }
        let r = registered_m / odometry_m;
        if !(r >= Self::RANGE.0 && r <= Self::RANGE.1) {
            return;
        }
        self.registered = Self::MEMORY * self.registered + registered_m;
        self.odometry = Self::MEMORY * self.odometry + odometry_m;
    }

    fn get(&self) -> f64 {
        if self.odometry < Self::MIN_DISTANCE_M {
            return 1.0;
        }
        (self.registered / self.odometry).clamp(Self::RANGE.0, Self::RANGE.1)
    }
}

pub struct GraphSlam {
    p: SlamParams,
    keyframes: Vec<Keyframe>,
    /// Downsampled scans (base frame), `max_scan_points` slots per keyframe.
    pool: Vec<[f32; 3]>,
    vars: Vec<Var>,
    factors: Vec<Factor>,
    solver: Option<Solver>,
    /// Prepared clouds: slot 0 is the new scan; the rest cache keyframes.
    clouds: Vec<PreparedCloud>,
    owner: Vec<Option<usize>>,
    /// Whether a cache slot's kd-tree has been built since it was loaded.
    built: Vec<bool>,
    next_victim: usize,
    /// The registration in progress.
    aligner: Option<Aligner>,
    /// The scan waiting to become a keyframe (base frame).
    pending: Vec<[f64; 3]>,
    pending_kf: Option<Keyframe>,
    candidates: HVec<Candidate, MAX_CANDIDATES>,
    /// Index stride of the interleaved feed of the pending scan.
    stride: usize,
    phase: Phase,
    stats: SlamStats,
    loop_closures: Vec<(usize, usize)>,
    last_loop_check: Option<LoopCheck>,
    last_unheld: Option<Unheld>,
    odometry_scale: OdometryScale,
}

impl GraphSlam {
    pub fn new(p: SlamParams) -> Self {
        let cap = p.keyframe_capacity.max(2);
        let slots = p.neighbors.clamp(1, MAX_CANDIDATES - 1) + 2;
        GraphSlam {
            keyframes: Vec::with_capacity(cap),
            pool: vec![[0.0; 3]; cap * p.max_scan_points],
            vars: Vec::with_capacity(cap + 1),
            factors: Vec::with_capacity(cap * (p.neighbors + 5)),
            solver: None,
            clouds: (0..slots)
                .map(|_| PreparedCloud::with_capacity(p.max_scan_points))
                .collect(),
            owner: vec![None; slots],
            built: vec![true; slots],
            next_victim: 1,
            aligner: None,
            pending: Vec::with_capacity(p.max_scan_points * 4),
            pending_kf: None,
            candidates: HVec::new(),
            stride: 1,
            phase: Phase::Idle,
            stats: SlamStats::default(),
            loop_closures: Vec::with_capacity(cap),
            last_loop_check: None,
            last_unheld: None,
            odometry_scale: OdometryScale::default(),
            p,
        }
    }

    pub fn params(&self) -> &SlamParams {
        &self.p
    }

    pub fn stats(&self) -> SlamStats {
        self.stats
    }

    pub fn is_idle(&self) -> bool {
        self.phase == Phase::Idle
    }

    pub fn keyframes(&self) -> &[Keyframe] {
        &self.keyframes
    }

    /// Optimised pose of keyframe `k` in the map frame.
    pub fn keyframe_pose(&self, k: usize) -> Pose {
        self.vars[k + 1].pose
    }

    /// The keyframe's downsampled scan (base frame).
    pub fn keyframe_scan(&self, k: usize) -> &[[f32; 3]] {
        let start = k * self.p.max_scan_points;
        &self.pool[start..start + self.keyframes[k].points]
    }

    /// Accepted loop closures (older keyframe, newer keyframe).
    pub fn loop_closures(&self) -> &[(usize, usize)] {
        &self.loop_closures
    }

    /// How the latest loop candidate fared.
    pub fn last_loop_check(&self) -> Option<LoopCheck> {
        self.last_loop_check
    }

    /// The latest registration that kept the guess somewhere.
    pub fn last_unheld(&self) -> Option<Unheld> {
        self.last_unheld
    }

    /// The IMU-to-LiDAR bias rotation (identity until estimated).
    pub fn bias(&self) -> Matrix3<f64> {
        self.vars.first().map_or(Matrix3::identity(), |v| v.pose.r)
    }

    /// Map pose of the rover now, from the odometry pose now: the last
    /// keyframe's optimised pose plus odometry since (scaled).
    pub fn pose(&self, odom_now: &Pose) -> Pose {
        match self.keyframes.last() {
            None => *odom_now,
            Some(kf) => {
                let k = self.keyframes.len() - 1;
                self.keyframe_pose(k)
                    .compose(&self.scale_odometry(&kf.odom.between(odom_now)))
            }
        }
    }

    /// The odometry's distance scale learned so far (1 until enough
    /// distance has been registered).
    pub fn odometry_scale(&self) -> f64 {
        self.odometry_scale.get()
    }

    /// A relative odometry pose with its translation scaled: what the
    /// rover truly moved, as the registrations measure it.
    pub fn scale_odometry(&self, rel: &Pose) -> Pose {
        Pose {
            r: rel.r,
            t: rel.t * self.odometry_scale.get(),
        }
    }

    /// Whether a scan taken at odometry pose `odom` should become a keyframe.
    pub fn wants_keyframe(&self, odom: &Pose) -> bool {
        let Some(kf) = self.keyframes.last() else {
            return true;
        };
        let rel = kf.odom.between(odom);
        let angle = crate::lie::log_so3(&rel.r).norm();
        rel.t.norm() >= self.p.keyframe_distance_m
            || angle >= self.p.keyframe_angle_deg.to_radians()
    }

    /// Offer a scan (base frame, deskewed) taken at `odom`; returns whether
    /// it was taken as the next keyframe.
    pub fn offer_scan(
        &mut self,
        stamp_ns: u64,
        odom: Pose,
        up_imu: Vector3<f64>,
        points: impl IntoIterator<Item = [f64; 3]>,
    ) -> bool {
        if !self.is_idle() {
            self.stats.scans_busy += 1;
            return false;
        }
        if self.keyframes.len() >= self.keyframes.capacity() {
            self.stats.keyframes_refused += 1;
            return false;
        }
        if !self.wants_keyframe(&odom) {
            return false;
        }
        self.pending.clear();
        for p in points {
            if self.pending.len() == self.pending.capacity() {
                break;
            }
            self.pending.push(p);
        }
        let up = if up_imu.norm() > 0.5 {
            up_imu.normalize()
        } else {
            Vector3::z()
        };
        self.pending_kf = Some(Keyframe {
            stamp_ns,
            odom,
            up_imu: up,
            points: 0,
            registration: None,
        });
        self.phase = Phase::Gather(0);
        true
    }

    /// The work the next [`GraphSlam::step`] does, for logs.
    pub fn work(&self) -> &'static str {
        match self.phase {
            Phase::Idle => "idle",
            Phase::Gather(_) => "gather",
            Phase::Build => "build",
            Phase::Covariances => "covariances",
            Phase::Register(_) => "register",
            Phase::Insert => "insert",
            Phase::Analyse => "analyse",
            Phase::Optimize { .. } => match self.solver.as_ref().map(Solver::stage) {
                Some("solve") => "optimize: factorise",
                Some("evaluate") => "optimize: evaluate",
                _ => "optimize: linearise",
            },
        }
    }

    /// The optimisation's unknowns and the non-zeros of its factor (0, 0
    /// before there is a system): what a factorisation's cost grows with.
    pub fn system_size(&self) -> (usize, usize) {
        self.solver
            .as_ref()
            .map_or((0, 0), |s| (s.unknowns(), s.nonzeros().1))
    }

    /// One bounded unit of work; returns false when idle.
    pub fn step(&mut self) -> bool {
        match self.phase {
            Phase::Idle => return false,
            Phase::Gather(from) => self.gather(from),
            Phase::Build => {
                self.clouds[0].build();
                self.stats.scan_points_dropped += self.clouds[0].stats().voxel.over_capacity as u64;
                self.owner[0] = None;
                self.phase = Phase::Covariances;
            }
            Phase::Covariances => {
                if self.clouds[0].estimate_covariances(self.p.points_per_step.max(1)) {
                    self.select_candidates();
                }
            }
            Phase::Register(i) => self.register(i),
            Phase::Insert => self.insert(),
            Phase::Analyse => {
                self.rebuild_solver();
                self.phase = Phase::Optimize {
                    accepted: 0,
                    calls: 0,
                };
            }
            Phase::Optimize { accepted, calls } => self.optimize(accepted, calls),
        }
        true
    }

    /// Predicted map pose of the pending keyframe.
    fn predicted(&self, kf: &Keyframe) -> Pose {
        self.pose(&kf.odom)
    }

    /// Feed the next part of the pending scan into the voxel grid. The
    /// points go in a golden-ratio interleaved order: a revolution arrives
    /// sorted by azimuth, and when its voxels exceed the grid's capacity the
    /// ones dropped must be spread over the whole scan, not be the last
    /// sector (which would leave keyframes seen from opposite headings
    /// nothing in common).
    fn gather(&mut self, from: usize) {
        let n = self.pending.len();
        if from == 0 {
            self.clouds[0].begin(self.p.voxel_m);
            self.stride = interleave_stride(n);
        }
        let to = from.saturating_add(self.p.points_per_step.max(1)).min(n);
        let (stride, pending) = (self.stride, &self.pending);
        self.clouds[0].add((from..to).map(|i| pending[(i * stride) % n]));
        self.phase = if to == n {
            Phase::Build
        } else {
            Phase::Gather(to)
        };
    }

    /// Candidates: the nearest recent keyframes and the best loop.
    fn select_candidates(&mut self) {
        self.candidates.clear();
        self.aligner = None;
        let Some(kf) = self.pending_kf else {
            self.phase = Phase::Idle;
            return;
        };
        let n = self.keyframes.len();
        if n == 0 {
            self.phase = Phase::Insert;
            return;
        }
        let here = self.predicted(&kf).t;
        let _ = self.candidates.push(Candidate {
            keyframe: n - 1,
            is_loop: false,
            refining: false,
            result: None,
            unheld: false,
        });
        let mut near: HVec<(f64, usize), 64> = HVec::new();
        let mut best_loop: Option<(f64, usize)> = None;
        for k in (0..n - 1).rev() {
            let t = self.keyframe_pose(k).t;
            if on_another_level(&t, &here) {
                continue;
            }
            let d = (t - here).norm();
            if n - k < self.p.loop_min_gap {
                if d <= self.p.neighbor_radius_m && near.len() < near.capacity() {
                    let _ = near.push((d, k));
                }
            } else if d <= self.p.loop_radius_m && best_loop.is_none_or(|(bd, _)| d < bd) {
                best_loop = Some((d, k));
            }
        }
        near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for &(_, k) in near.iter().take(self.p.neighbors.saturating_sub(1)) {
            let _ = self.candidates.push(Candidate {
                keyframe: k,
                is_loop: false,
                refining: false,
                result: None,
                unheld: false,
            });
        }
        if let Some((_, k)) = best_loop {
            let _ = self.candidates.push(Candidate {
                keyframe: k,
                is_loop: true,
                refining: false,
                result: None,
                unheld: false,
            });
        }
        self.phase = Phase::Register(0);
    }

    /// The cache slot of keyframe `k`'s cloud, if it is there (possibly
    /// still being prepared).
    fn cached_slot(&self, k: usize) -> Option<usize> {
        (1..self.clouds.len()).find(|&s| self.owner[s] == Some(k))
    }

    /// Start preparing keyframe `k`'s cloud in the least recently filled
    /// slot: its stored points (already downsampled: every one is kept)
    /// and the kd-tree; the covariances follow in later steps.
    fn load_target(&mut self, k: usize) {
        let s = self.next_victim;
        self.next_victim = if s + 1 >= self.clouds.len() { 1 } else { s + 1 };
        let start = k * self.p.max_scan_points;
        let pts = &self.pool[start..start + self.keyframes[k].points];
        let cloud = &mut self.clouds[s];
        cloud.begin(0.0);
        cloud.add(pts.iter().map(|p| [p[0] as f64, p[1] as f64, p[2] as f64]));
        self.owner[s] = Some(k);
        self.built[s] = false;
    }

    /// One bounded part of registering the new scan to candidate `i`: load
    /// the target, its covariances, then GICP a part of a pass at a time.
    fn register(&mut self, i: usize) {
        if i >= self.candidates.len() {
            self.phase = Phase::Insert;
            return;
        }
        let Some(kf) = self.pending_kf else {
            self.phase = Phase::Idle;
            return;
        };
        let k = self.candidates[i].keyframe;
        let Some(slot) = self.cached_slot(k) else {
            self.load_target(k);
            return;
        };
        if !self.built[slot] {
            // The kd-tree in a step of its own.
            self.clouds[slot].build();
            self.built[slot] = true;
            return;
        }
        let budget = self.p.points_per_step.max(1);
        if !self.clouds[slot].is_ready() {
            self.clouds[slot].estimate_covariances(budget);
            return;
        }
        let init = self
            .keyframe_pose(k)
            .between(&self.predicted(&kf))
            .to_isometry();
        let aligner = self.aligner.get_or_insert_with(|| Aligner::new(&init));
        let refining = self.candidates[i].refining;
        let params = if refining {
            let (reach, mutual) = if self.candidates[i].is_loop {
                (self.p.loop_verify_distance_m, false)
            } else {
                (self.p.refine_distance_m, self.p.refine_mutual)
            };
            GicpParams {
                max_correspondence_m: reach,
                mutual,
                // Only the refined alignment is judged (and only when the
                // check is on): the sums cost three 3x3 products a pair.
                surface_information: self.p.min_surface_share > 0.0,
                ..self.p.gicp
            }
        } else {
            self.p.gicp
        };
        let (src, rest) = self.clouds.split_at_mut(1);
        if !aligner.step(&src[0], &rest[slot - 1], &params, budget) {
            return;
        }
        let mut result = aligner.result();
        if !refining {
            self.candidates[i].refining = true;
            self.aligner = Some(Aligner::new(&result.transform));
            return;
        }
        // The guess the wide pass started from: what unheld directions keep.
        let (directions, share) =
            keep_guess_where_unheld(&mut result, &init, self.p.min_surface_share);
        if directions > 0 {
            self.stats.registrations_unheld += 1;
            self.candidates[i].unheld = true;
            self.last_unheld = Some(Unheld {
                target: k,
                directions,
                surface_share: share,
            });
        }
        self.candidates[i].result = Some(result);
        self.aligner = None;
        self.stats.registrations += 1;
        self.phase = Phase::Register(i + 1);
    }

    fn insert(&mut self) {
        let Some(mut kf) = self.pending_kf.take() else {
            self.phase = Phase::Idle;
            return;
        };
        let k = self.keyframes.len();
        // Keep the downsampled scan.
        let cloud = &self.clouds[0];
        let n = cloud.len().min(self.p.max_scan_points);
        let start = k * self.p.max_scan_points;
        for (dst, src) in self.pool[start..start + n].iter_mut().zip(cloud.points()) {
            *dst = [src[0] as f32, src[1] as f32, src[2] as f32];
        }
        kf.points = n;
        let predicted = self.predicted(&kf);
        if k == 0 {
            self.vars.push(Var {
                pose: Pose::identity(),
                kind: VarKind::Tilt,
                fixed: !self.p.estimate_bias,
                rigid: None,
            });
            // Weak prior: the bias is small; gravity observes it over time.
            self.factors.push(Factor::RotationPrior {
                i: BIAS,
                r: Matrix3::identity(),
                sqrt_weight: 1.0 / self.p.bias_prior_deg.max(1e-3).to_radians(),
            });
        }
        self.vars.push(Var {
            pose: predicted,
            kind: VarKind::Pose3,
            fixed: false,
            rigid: None,
        });
        let var = k + 1;
        if k == 0 {
            self.factors.push(Factor::Anchor {
                i: var,
                position: predicted.t,
                yaw: predicted.yaw(),
                sqrt_weight: 1e3,
            });
        } else {
            let prev = &self.keyframes[k - 1];
            let z = self.scale_odometry(&prev.odom.between(&kf.odom));
            let d = z.t.norm().max(0.05);
            let dt = kf.stamp_ns.saturating_sub(prev.stamp_ns) as f64 * 1e-9;
            let st = 1.0 / (self.p.odom_sigma_m_per_m * d);
            let sz = 1.0 / (self.p.odom_sigma_vertical_m_per_m * d);
            let sr = 1.0
                / (self.p.odom_sigma_rad_per_m * d)
                    .hypot(self.p.odom_sigma_rad_per_s * dt)
                    .max(1e-9);
            let u = Matrix6::from_diagonal(&nalgebra::Vector6::new(st, st, sz, sr, sr, sr));
            // Robust too: spinning wheels (a rover stuck nose-up) report
            // travel that the scans do not see.
            self.factors.push(Factor::Between {
                i: var - 1,
                j: var,
                z,
                sqrt_info: u,
                robust: Robust::Cauchy(self.p.robust_scale),
            });
        }
        self.factors.push(Factor::Inclination {
            pose: var,
            bias: BIAS,
            up: kf.up_imu,
            sqrt_weight: 1.0 / self.p.inclination_sigma_deg.to_radians(),
        });
        for c in self.candidates.clone() {
            let Some(a) = c.result else { continue };
            let ok = if c.is_loop {
                a.fitness <= self.p.loop_max_fitness_m
                    && a.inlier_fraction >= self.p.loop_min_inlier_fraction
            } else {
                a.inlier_fraction >= 0.3
            };
            if c.is_loop {
                let weak = weakest_translation(&(a.hessian * self.p.gicp_information_scale));
                self.last_loop_check = Some(LoopCheck {
                    older: c.keyframe,
                    newer: k,
                    fitness_m: a.fitness,
                    inlier_fraction: a.inlier_fraction,
                    iterations: a.iterations,
                    accepted: ok,
                    weakest_info: weak.0,
                    weakest_axis: weak.1,
                });
            }
            if !ok {
                if c.is_loop {
                    self.stats.loop_candidates_rejected += 1;
                } else {
                    self.stats.registrations_rejected += 1;
                }
                continue;
            }
            let info = a.hessian * self.p.gicp_information_scale + Matrix6::identity() * 1e-6;
            let Some(ch) = info.cholesky() else {
                self.stats.registrations_rejected += 1;
                continue;
            };
            if c.keyframe + 1 == k {
                kf.registration = Some(self.factors.len());
                let odometry = self.keyframes[k - 1].odom.between(&kf.odom);
                // Where the scans kept the guess they say nothing of slip.
                if !c.unheld {
                    self.odometry_scale
                        .add(a.transform.translation.vector.norm(), odometry.t.norm());
                }
            }
            self.factors.push(Factor::Between {
                i: c.keyframe + 1,
                j: var,
                z: Pose::from_isometry(&a.transform),
                sqrt_info: ch.l().transpose(),
                robust: Robust::Cauchy(self.p.robust_scale),
            });
            if c.is_loop {
                self.stats.loop_closures += 1;
                if self.loop_closures.len() < self.loop_closures.capacity() {
                    self.loop_closures.push((c.keyframe, k));
                }
            }
        }
        self.keyframes.push(kf);
        self.stats.keyframes += 1;
        // The new scan's prepared cloud becomes the newest cache entry.
        let s = self.next_victim;
        self.next_victim = if s + 1 >= self.clouds.len() { 1 } else { s + 1 };
        self.clouds.swap(0, s);
        self.owner[s] = Some(k);
        self.built[s] = true;
        self.owner[0] = None;
        // The keyframe leaving the active window joins its sub-map, led by
        // the sub-map's first keyframe, at their present relative pose.
        let active = self.p.active_keyframes.max(2);
        if self.keyframes.len() > active {
            let leaving = self.keyframes.len() - active - 1;
            let root = leaving - leaving % self.p.submap_keyframes.max(1);
            if root != leaving && self.vars[leaving + 1].rigid.is_none() {
                let offset = self
                    .keyframe_pose(root)
                    .between(&self.keyframe_pose(leaving));
                self.vars[leaving + 1].rigid = Some(Rigid {
                    parent: root + 1,
                    offset,
                });
                self.stats.grouped += 1;
            }
        }
        self.phase = Phase::Analyse;
    }

    /// A bounded part of an LM iteration per step (`factors_per_step`
    /// factors, or one factorisation); a rejected iteration is followed by
    /// one with more damping; at most twice `iterations_per_keyframe`
    /// iterations.
    fn optimize(&mut self, accepted: u32, calls: u32) {
        let Some(solver) = self.solver.as_mut() else {
            self.phase = Phase::Idle;
            return;
        };
        let quantum = self.p.factors_per_step;
        let Some(step) = solver.advance(&mut self.vars, &self.factors, quantum) else {
            return;
        };
        self.stats.lm_iterations += 1;
        let accepted = accepted + matches!(step, Step::Accepted { .. }) as u32;
        let calls = calls + 1;
        let budget = self.p.iterations_per_keyframe;
        self.phase = if step == Step::Converged || accepted >= budget || calls >= 2 * budget {
            Phase::Idle
        } else {
            Phase::Optimize { accepted, calls }
        };
    }

    /// The square-root information of the registration factor that joined
    /// keyframe `k` to its predecessor, if it was accepted: what a loop
    /// closure of the same quality would carry.
    pub fn registration_information(&self, k: usize) -> Option<Matrix6<f64>> {
        match self.factors.get(self.keyframes.get(k)?.registration?)? {
            Factor::Between { sqrt_info, .. } => Some(*sqrt_info),
            _ => None,
        }
    }

    /// Adds a loop closure found outside the pipeline (place recognition,
    /// an operator, fault injection): `z` is keyframe `newer` in the frame
    /// of keyframe `older`. It goes under the same robust kernel as the
    /// pipeline's own, so a wrong one cannot wreck the map. Only between
    /// keyframes, when idle; the optimisation restarts.
    pub fn add_loop_closure(
        &mut self,
        older: usize,
        newer: usize,
        z: Pose,
        sqrt_info: Matrix6<f64>,
    ) -> Result<(), LoopClosureError> {
        if !self.is_idle() {
            return Err(LoopClosureError::Busy);
        }
        let n = self.keyframes.len();
        if older >= newer || newer >= n {
            return Err(LoopClosureError::NoSuchKeyframes { older, newer, n });
        }
        if self.factors.len() == self.factors.capacity() {
            return Err(LoopClosureError::Full);
        }
        self.factors.push(Factor::Between {
            i: older + 1,
            j: newer + 1,
            z,
            sqrt_info,
            robust: Robust::Cauchy(self.p.robust_scale),
        });
        self.stats.loop_closures += 1;
        self.stats.external_loop_closures += 1;
        if self.loop_closures.len() < self.loop_closures.capacity() {
            self.loop_closures.push((older, newer));
        }
        self.phase = Phase::Analyse;
        Ok(())
    }

    fn rebuild_solver(&mut self) {
        self.solver = match Solver::new(&self.vars, &self.factors, SLAM_LM) {
            Ok(s) => Some(s),
            Err(_) => {
                self.stats.solver_failures += 1;
                None
            }
        };
    }

    /// Process everything pending (offline use and tests).
    pub fn run_to_idle(&mut self) {
        while self.step() {}
    }
}

/// Keyframes more than this over or under each other...
const LEVEL_MIN_DZ_M: f64 = 1.0;
/// ...and steeper than this from each other (rise over run; no rover
/// drives a slope of 27 degrees) lie on different levels.
const LEVEL_MIN_GRADE: f64 = 0.5;

/// Whether keyframe positions `a` and `b` lie on different levels (a
/// garage's floors, a passage over another), where they are never
/// registered to each other: one level's floor and the underside of the
/// slab over the level below are parallel planes a slab apart, and GICP
/// pairs them. In the garage, level 1's keyframes registered to level 0's
/// ones below them (nearest in 3D, 3 m down) and the map's level 1 sank
/// 0.4 m, the slab's thickness and more.
fn on_another_level(a: &Vector3<f64>, b: &Vector3<f64>) -> bool {
    let dz = (a.z - b.z).abs();
    let run = (a.x - b.x).hypot(a.y - b.y);
    dz > LEVEL_MIN_DZ_M && dz > LEVEL_MIN_GRADE * run
}

#[cfg(test)]
mod tests {
    use super::{interleave_stride, on_another_level, weakest_translation, OdometryScale};
    use nalgebra::{Matrix6, Vector3, Vector6};

    #[test]
    fn the_weakest_translation_is_the_direction_a_plane_leaves_free() {
        // Translation well held along x and z, hardly along y; rotation
        // entries large, which must not enter.
        let mut h = Matrix6::from_diagonal(&Vector6::new(400.0, 0.5, 900.0, 1e5, 1e5, 1e5));
        h[(0, 2)] = 30.0;
        h[(2, 0)] = 30.0;
        let (info, axis) = weakest_translation(&h);
        assert!((info - 0.5).abs() < 1e-9, "{info}");
        assert!((axis[1].abs() - 1.0).abs() < 1e-9, "{axis:?}");
    }

    #[test]
    fn keyframes_over_each_other_are_on_other_levels_along_a_ramp_they_are_not() {
        let v = Vector3::new;
        // A garage level over the one below, straight up or 4 m off.
        assert!(on_another_level(&v(5.0, 2.0, 3.0), &v(5.0, 2.0, 0.0)));
        assert!(on_another_level(&v(5.0, 2.0, 3.0), &v(9.0, 2.0, 0.0)));
        // Along a 14-degree ramp, 8 m apart: 2 m of rise, one way.
        assert!(!on_another_level(&v(0.0, 0.0, 0.0), &v(8.0, 0.0, 2.0)));
        // A rough floor's bumps, however near.
        assert!(!on_another_level(&v(0.0, 0.0, 0.0), &v(0.3, 0.0, 0.4)));
    }

    #[test]
    fn the_odometry_scale_follows_the_registrations_and_ignores_outliers() {
        let mut s = OdometryScale::default();
        // Too little distance yet: no correction.
        s.add(0.97, 1.0);
        s.add(0.97, 1.0);
        assert_eq!(s.get(), 1.0);
        for _ in 0..40 {
            s.add(0.965, 1.0);
        }
        assert!((s.get() - 0.965).abs() < 0.002, "{}", s.get());
        // Spinning wheels (no registered motion), a bad match, standing
        // still, a non-finite value: all ignored.
        let before = s.get();
        s.add(0.02, 1.0);
        s.add(2.0, 1.0);
        s.add(0.0, 0.05);
        s.add(f64::NAN, 1.0);
        assert_eq!(s.get(), before);
        // A change of ground is followed within some twenty keyframes.
        for _ in 0..60 {
            s.add(0.9, 1.0);
        }
        assert!((s.get() - 0.9).abs() < 0.005, "{}", s.get());
    }

    #[test]
    fn the_interleaved_order_visits_every_point_once() {
        for n in [1, 2, 3, 10, 64, 1000, 65_536, 69_999] {
            let s = interleave_stride(n);
            let mut seen = vec![false; n];
            for i in 0..n {
                let k = (i * s) % n;
                assert!(!seen[k], "n {n}: {k} twice");
                seen[k] = true;
            }
        }
    }
}
