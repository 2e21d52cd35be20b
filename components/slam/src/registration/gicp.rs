//! Generalized-ICP (Segal, Haehnel, Thrun 2009) between two prepared
//! clouds.
//!
//! Cost, over source points `p` (covariance `C_s`) matched to their nearest
//! target point `q` (covariance `C_t`) within a maximum distance:
//!
//! ```text
//! E(T) = 1/2 sum rho(s),   s = d^T (C_t + R C_s R^T)^-1 d,   d = q - (R p + t)
//! ```
//!
//! with `rho` the robust kernel. It is minimised by Gauss-Newton with a
//! small Levenberg damping, re-associating nearest neighbours every
//! iteration, over the perturbation `T <- (R Exp(phi), t + R dt)`, ordered
//! `[dt; phi]`. Why that parametrisation: both halves live in the source
//! frame, where a point's residual is `e = p - R^T (q - t)` (that is
//! `-R^T d`) and its Jacobian `[I, -[p]x]` involves neither `R` nor `t`;
//! and the pose-graph back end uses the same right perturbation for the
//! scan factor whose information is [`Alignment::hessian`].

use nalgebra::{Isometry3, Matrix3, Matrix6, Translation3, UnitQuaternion, Vector3, Vector6};

use super::covariance::{self, DEFAULT_NEIGHBORS, PLANE_EPSILON};
use super::kdtree::{KdTree, MAX_K};
use super::voxel::{VoxelGrid, VoxelStats};

/// A robust kernel on the squared Mahalanobis distance `s` of a
/// correspondence. With the plane-regularised covariances, a point `x`
/// metres off a matching plane along its normal has `s ~ x^2 / (2 eps)`
/// (`eps` = [`PLANE_EPSILON`]: 1 cm gives `s` = 0.05, 10 cm gives 5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kernel {
    /// Plain least squares: `rho(s) = s`.
    None,
    /// Quadratic up to a Mahalanobis distance `delta`, linear beyond:
    /// `rho(s) = s` for `sqrt(s) <= delta`, else `2 delta sqrt(s) - delta^2`.
    Huber { delta: f64 },
    /// `rho(s) = c^2 s / (c^2 + s)`: far correspondences stop pulling.
    GemanMcClure { c: f64 },
}

impl Kernel {
    /// `(rho(s), rho'(s))`: the cost and the weight of the iteratively
    /// reweighted Gauss-Newton step.
    #[inline]
    fn eval(self, s: f64) -> (f64, f64) {
        match self {
            Kernel::None => (s, 1.0),
            Kernel::Huber { delta } => {
                let e = s.sqrt();
                if e <= delta {
                    (s, 1.0)
                } else {
                    (2.0 * delta * e - delta * delta, delta / e)
                }
            }
            Kernel::GemanMcClure { c } => {
                let c2 = c * c;
                let den = c2 + s;
                (c2 * s / den, (c2 / den) * (c2 / den))
            }
        }
    }
}

/// Registration settings. The defaults are small_gicp's (1.0.1), so the two
/// can be compared on the same data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GicpParams {
    /// Source points farther than this from every target point (after
    /// transformation) take no part in an iteration, metres.
    pub max_correspondence_m: f64,
    pub max_iterations: u32,
    /// Converged when an update moves less than this...
    pub translation_eps_m: f64,
    /// ...and rotates less than this (radians).
    pub rotation_eps_rad: f64,
    pub kernel: Kernel,
    /// Levenberg damping added to the Hessian's diagonal: keeps a step
    /// finite along directions the geometry leaves unconstrained (a
    /// corridor's axis) without slowing the constrained ones.
    pub damping: f64,
    /// Keep only mutual nearest neighbours: the target point's nearest
    /// source point must be the one that found it. Where the source sees
    /// beyond the target's coverage, its edge points pair with the
    /// target's last points, which have nearer partners of their own:
    /// the check drops those pairs, which pull the motion short.
    pub mutual: bool,
    /// Also sum [`Alignment::plane_information`] (three 3x3 products more
    /// per pair), for `registration::degeneracy`.
    pub surface_information: bool,
}

impl Default for GicpParams {
    fn default() -> Self {
        GicpParams {
            max_correspondence_m: 1.0,
            max_iterations: 20,
            translation_eps_m: 1e-3,
            rotation_eps_rad: 0.1f64.to_radians(),
            kernel: Kernel::None,
            damping: 1e-3,
            mutual: false,
            surface_information: false,
        }
    }
}

/// What [`PreparedCloud::prepare`] kept and dropped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PrepareStats {
    /// Points read, and what the voxel grid made of them.
    pub voxel: VoxelStats,
    /// Points in the prepared cloud.
    pub points: usize,
}

/// A cloud ready for registration: voxel-downsampled points (tree order),
/// their regularised covariances and a kd-tree over them, in buffers sized
/// once by [`with_capacity`](Self::with_capacity).
#[derive(Clone, Debug)]
pub struct PreparedCloud {
    grid: VoxelGrid,
    tree: KdTree,
    covs: Vec<Matrix3<f64>>,
    neighbors: usize,
    stats: PrepareStats,
}

impl PreparedCloud {
    /// Room for `max_points` points after downsampling; further points are
    /// counted ([`VoxelStats::over_capacity`]) and dropped.
    pub fn with_capacity(max_points: usize) -> Self {
        PreparedCloud {
            grid: VoxelGrid::with_capacity(max_points),
            tree: KdTree::with_capacity(max_points),
            covs: Vec::with_capacity(max_points),
            neighbors: DEFAULT_NEIGHBORS,
            stats: PrepareStats::default(),
        }
    }

    /// Neighbours per covariance (default 10), clamped to 3..=64.
    pub fn with_neighbors(mut self, k: usize) -> Self {
        self.neighbors = k.clamp(3, MAX_K);
        self
    }

    /// Replace the content: downsample `points` to voxels of `voxel_m`
    /// metres (not positive: keep every point), build the kd-tree, estimate
    /// covariances. Non-finite points are dropped. Allocates nothing.
    pub fn prepare(
        &mut self,
        points: impl IntoIterator<Item = [f64; 3]>,
        voxel_m: f64,
    ) -> PrepareStats {
        self.begin(voxel_m);
        self.add(points);
        self.build();
        while !self.estimate_covariances(usize::MAX) {}
        self.stats
    }

    /// [`prepare`](Self::prepare) in bounded parts: `begin`, any number of
    /// `add`, `build` (the kd-tree), then `estimate_covariances` until it
    /// returns true. Same result as one `prepare` of all the parts.
    pub fn begin(&mut self, voxel_m: f64) {
        self.grid.begin(voxel_m);
        self.covs.clear();
    }

    pub fn add(&mut self, points: impl IntoIterator<Item = [f64; 3]>) {
        self.grid.add(points);
    }

    /// Finish the downsampling and build the kd-tree.
    pub fn build(&mut self) {
        let voxel = self.grid.finish();
        self.tree.build(self.grid.points());
        self.covs.clear();
        self.stats = PrepareStats {
            voxel,
            points: self.tree.len(),
        };
    }

    /// Covariances of at most `max_points` more points; true when all are
    /// done (the cloud is ready for [`align`]).
    pub fn estimate_covariances(&mut self, max_points: usize) -> bool {
        covariance::estimate_next(
            &self.tree,
            self.neighbors,
            PLANE_EPSILON,
            &mut self.covs,
            max_points,
        )
    }

    /// Every point has its covariance.
    pub fn is_ready(&self) -> bool {
        self.covs.len() == self.tree.len()
    }

    pub fn capacity(&self) -> usize {
        self.tree.capacity()
    }

    pub fn len(&self) -> usize {
        self.tree.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tree.is_empty()
    }

    /// The prepared points, in kd-tree order.
    pub fn points(&self) -> &[[f64; 3]] {
        self.tree.points()
    }

    /// Covariance of each point of [`points`](Self::points).
    pub fn covariances(&self) -> &[Matrix3<f64>] {
        &self.covs
    }

    pub fn tree(&self) -> &KdTree {
        &self.tree
    }

    /// What the last [`prepare`](Self::prepare) kept and dropped.
    pub fn stats(&self) -> PrepareStats {
        self.stats
    }
}

/// The result of [`align`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    /// Maps source points into the target frame (target <- source).
    pub transform: Isometry3<f64>,
    /// Gauss-Newton iterations run (each one nearest-neighbour pass).
    pub iterations: u32,
    /// The last update was below both thresholds.
    pub converged: bool,
    /// Source points with a target point within the maximum distance.
    pub inliers: usize,
    /// RMS distance of the inlier correspondences, metres (0 without any).
    pub fitness: f64,
    /// `inliers` over the source points.
    pub inlier_fraction: f64,
    /// Gauss-Newton Hessian `sum w J^T W J` of the cost `1/2 sum rho(s)`
    /// (so the information matrix of the alignment), with respect to
    /// `T <- (R Exp(phi), t + R dt)`, ordered `[dt; phi]`, both in the
    /// source frame; `w` is the kernel's weight. Evaluated with the last
    /// iteration's correspondences, i.e. at most one converged update
    /// (below the thresholds) before `transform`. Zero without inliers.
    pub hessian: Matrix6<f64>,
    /// The part of `hessian` the surfaces' normals carry: the same sum with
    /// each pair's information reduced to its component along the target's
    /// normal (`(n^T W n) n n^T`). GICP's regularised covariances keep a
    /// weight of 1/2 in the plane of every patch, which on a bare plane
    /// pairs each LiDAR ring with itself and reads the motion as zero,
    /// confidently: along those directions this carries (almost) none of
    /// the Hessian's information, where the surfaces hold it nearly all.
    /// `None` unless asked for (`GicpParams::surface_information`).
    pub plane_information: Option<Matrix6<f64>>,
}

/// One pass over the source: nearest neighbours and the normal equations.
struct Linearization {
    h: Matrix6<f64>,
    hn: Matrix6<f64>,
    b: Vector6<f64>,
    cost: f64,
    inliers: usize,
    sum_dist_sq: f64,
}

#[inline(always)]
fn hat(p: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -p.z, p.y, p.z, 0.0, -p.x, -p.y, p.x, 0.0)
}

/// Symmetric 3x3 inverse by cofactors (stack only); `None` if singular.
#[inline(always)]
fn inverse_sym(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let (a, b, c) = (m[(0, 0)], m[(0, 1)], m[(0, 2)]);
    let (d, e) = (m[(1, 1)], m[(1, 2)]);
    let f = m[(2, 2)];
    let c00 = d * f - e * e;
    let c01 = c * e - b * f;
    let c02 = b * e - c * d;
    let det = a * c00 + b * c01 + c * c02;
    if det.is_nan() || det.abs() <= 1e-300 {
        return None;
    }
    let k = 1.0 / det;
    let c11 = a * f - c * c;
    let c12 = b * c - a * e;
    let c22 = a * d - b * b;
    Some(Matrix3::new(
        c00 * k,
        c01 * k,
        c02 * k,
        c01 * k,
        c11 * k,
        c12 * k,
        c02 * k,
        c12 * k,
        c22 * k,
    ))
}

/// Partial sums of one linearisation pass over the source, accumulated in
/// source order so that a pass split into parts gives the same bits.
#[derive(Clone, Copy, Debug)]
struct Accumulator {
    htt: Matrix3<f64>,
    htp: Matrix3<f64>,
    hpp: Matrix3<f64>,
    /// The normals-only sums (see [`Alignment::plane_information`]).
    ntt: Matrix3<f64>,
    ntp: Matrix3<f64>,
    npp: Matrix3<f64>,
    bt: Vector3<f64>,
    bp: Vector3<f64>,
    cost: f64,
    inliers: usize,
    sum_dist_sq: f64,
    /// The previous source point's match (source points are in tree order,
    /// so consecutive ones are close): its distance bounds the search.
    prev: Option<usize>,
    /// Next source point to visit.
    next: usize,
}

impl Accumulator {
    fn new() -> Self {
        Accumulator {
            htt: Matrix3::zeros(),
            htp: Matrix3::zeros(),
            hpp: Matrix3::zeros(),
            ntt: Matrix3::zeros(),
            ntp: Matrix3::zeros(),
            npp: Matrix3::zeros(),
            bt: Vector3::zeros(),
            bp: Vector3::zeros(),
            cost: 0.0,
            inliers: 0,
            sum_dist_sq: 0.0,
            prev: None,
            next: 0,
        }
    }

    fn finish(&self) -> Linearization {
        let h = symmetric_from_blocks(&self.htt, &self.htp, &self.hpp);
        let hn = symmetric_from_blocks(&self.ntt, &self.ntp, &self.npp);
        let mut b = Vector6::zeros();
        b.fixed_rows_mut::<3>(0).copy_from(&self.bt);
        b.fixed_rows_mut::<3>(3).copy_from(&self.bp);
        Linearization {
            h,
            hn,
            b,
            cost: 0.5 * self.cost,
            inliers: self.inliers,
            sum_dist_sq: self.sum_dist_sq,
        }
    }
}

/// The symmetric 6x6 `[tt tp; tp^T pp]`.
fn symmetric_from_blocks(tt: &Matrix3<f64>, tp: &Matrix3<f64>, pp: &Matrix3<f64>) -> Matrix6<f64> {
    let mut h = Matrix6::zeros();
    h.fixed_view_mut::<3, 3>(0, 0).copy_from(tt);
    h.fixed_view_mut::<3, 3>(0, 3).copy_from(tp);
    h.fixed_view_mut::<3, 3>(3, 0).copy_from(&tp.transpose());
    h.fixed_view_mut::<3, 3>(3, 3).copy_from(pp);
    h
}

/// Nearest neighbours and the (reweighted) normal equations at `tf`.
/// Source points in tree order, fixed summation order: reproducible bits.
fn linearize(
    source: &PreparedCloud,
    target: &PreparedCloud,
    tf: &Isometry3<f64>,
    params: &GicpParams,
) -> Linearization {
    let mut acc = Accumulator::new();
    accumulate(source, target, tf, params, &mut acc, usize::MAX);
    acc.finish()
}

/// Add at most `max_points` more source points to the pass in `acc`;
/// true when the pass has visited every source point.
fn accumulate(
    source: &PreparedCloud,
    target: &PreparedCloud,
    tf: &Isometry3<f64>,
    params: &GicpParams,
    acc: &mut Accumulator,
    max_points: usize,
) -> bool {
    let r = tf.rotation.to_rotation_matrix();
    let rm = r.matrix();
    let rt = rm.transpose();
    let t = tf.translation.vector;
    let max_sq = params.max_correspondence_m * params.max_correspondence_m;
    let tpts = target.points();
    let tcov = target.covariances();
    let n = source.len();
    let start = acc.next.min(n);
    let end = start.saturating_add(max_points).min(n);
    let sp = &source.points()[start..end];
    let sc = &source.covariances()[start..end];
    for (i, (p, cs)) in sp.iter().zip(sc).enumerate() {
        let pv = Vector3::new(p[0], p[1], p[2]);
        let x = rm * pv + t;
        let xa = [x.x, x.y, x.z];
        let bound = match acc.prev {
            Some(j) => {
                let q = &tpts[j];
                let d = (q[0] - xa[0]).powi(2) + (q[1] - xa[1]).powi(2) + (q[2] - xa[2]).powi(2);
                d.min(max_sq)
            }
            None => max_sq,
        };
        // The bound only speeds the search up: should rounding leave the
        // previous match outside it, search the whole radius again.
        let found = match target.tree.nearest(&xa, bound) {
            None if bound < max_sq => target.tree.nearest(&xa, max_sq),
            r => r,
        };
        let Some(nn) = found else {
            acc.prev = None;
            continue;
        };
        acc.prev = Some(nn.index as usize);
        let j = nn.index as usize;
        let q = &tpts[j];
        if params.mutual {
            // The target point in the source frame; its nearest source
            // point lies within the pair's distance (this one is there).
            let back = rt * (Vector3::new(q[0], q[1], q[2]) - t);
            let own = start + i;
            let mine = source
                .tree
                .nearest(&[back.x, back.y, back.z], nn.dist_sq * (1.0 + 1e-9) + 1e-12);
            if mine.is_some_and(|m| m.index as usize != own) {
                continue;
            }
        }
        // Everything in the source frame: residual e = p - R^T (q - t) and
        // information W = (R^T C_t R + C_s)^-1, so that s = e^T W e.
        let e = rt * (x - Vector3::new(q[0], q[1], q[2]));
        let Some(w) = inverse_sym(&(rt * tcov[j] * rm + cs)) else {
            continue;
        };
        let we = w * e;
        let s = e.dot(&we);
        let (rho, k) = params.kernel.eval(s);
        if !(rho.is_finite() && k.is_finite()) {
            continue;
        }
        acc.inliers += 1;
        acc.sum_dist_sq += nn.dist_sq;
        acc.cost += rho;
        // J = [I, -[p]x]: H += k J^T W J, b += k J^T W e.
        let ph = hat(&pv);
        let kw = w * k;
        let kwp = kw * ph;
        acc.htt += kw;
        acc.htp -= kwp;
        acc.hpp -= ph * kwp;
        acc.bt += we * k;
        acc.bp += ph * we * k;
        if params.surface_information {
            // The part of k W along the target's normal n: k (n^T W n) n n^T,
            // with n n^T = (I - C_t) / (1 - eps) in the source frame.
            let nn = rt * (Matrix3::identity() - tcov[j]) * rm * (1.0 / (1.0 - PLANE_EPSILON));
            let normal = nn * (k * nn.component_mul(&w).sum());
            let normal_p = normal * ph;
            acc.ntt += normal;
            acc.ntp -= normal_p;
            acc.npp -= ph * normal_p;
        }
    }
    acc.next = end;
    end == n
}

/// `T (dt, Exp(phi))`: the perturbation of [`Alignment::hessian`].
pub fn perturb(tf: &Isometry3<f64>, delta: &Vector6<f64>) -> Isometry3<f64> {
    let dt = Vector3::new(delta[0], delta[1], delta[2]);
    let phi = Vector3::new(delta[3], delta[4], delta[5]);
    let mut out = tf
        * Isometry3::from_parts(
            Translation3::from(dt),
            UnitQuaternion::from_scaled_axis(phi),
        );
    out.rotation.renormalize();
    out
}

/// The GICP cost `1/2 sum rho(s)` at `tf` with nearest-neighbour
/// correspondences, and the number of inliers: what [`align`] minimises.
pub fn cost(
    source: &PreparedCloud,
    target: &PreparedCloud,
    tf: &Isometry3<f64>,
    params: &GicpParams,
) -> (f64, usize) {
    let l = linearize(source, target, tf, params);
    (l.cost, l.inliers)
}

/// Register `source` onto `target` starting from `init` (target <- source).
/// Single-threaded, allocation-free and bit-reproducible. Never panics: an
/// empty cloud, no correspondences or a singular system end the iterations
/// with `converged == false`.
pub fn align(
    source: &PreparedCloud,
    target: &PreparedCloud,
    init: &Isometry3<f64>,
    params: &GicpParams,
) -> Alignment {
    let mut a = Aligner::new(init);
    while !a.step(source, target, params, usize::MAX) {}
    a.result()
}

/// [`align`] in bounded units of work: each [`step`](Aligner::step) visits
/// at most a given number of source points, and a Gauss-Newton update
/// follows every complete pass. The steps together give the same bits as
/// one `align`, however the work is cut.
#[derive(Clone, Copy, Debug)]
pub struct Aligner {
    tf: Isometry3<f64>,
    out: Alignment,
    acc: Accumulator,
    done: bool,
}

impl Aligner {
    pub fn new(init: &Isometry3<f64>) -> Self {
        Aligner {
            tf: *init,
            out: Alignment {
                transform: *init,
                iterations: 0,
                converged: false,
                inliers: 0,
                fitness: 0.0,
                inlier_fraction: 0.0,
                hessian: Matrix6::zeros(),
                plane_information: None,
            },
            acc: Accumulator::new(),
            done: false,
        }
    }

    pub fn is_done(&self) -> bool {
        self.done
    }

    /// The alignment so far (final once [`is_done`](Self::is_done)).
    pub fn result(&self) -> Alignment {
        self.out
    }

    /// Visit at most `max_points` source points; true when finished.
    pub fn step(
        &mut self,
        source: &PreparedCloud,
        target: &PreparedCloud,
        params: &GicpParams,
        max_points: usize,
    ) -> bool {
        if self.done {
            return true;
        }
        let max_d = params.max_correspondence_m;
        if source.is_empty()
            || target.is_empty()
            || max_d.is_nan()
            || max_d <= 0.0
            || self.out.iterations >= params.max_iterations
        {
            self.done = true;
            return true;
        }
        if !accumulate(source, target, &self.tf, params, &mut self.acc, max_points) {
            return false;
        }
        let lin = self.acc.finish();
        self.acc = Accumulator::new();
        self.done = self.update(&lin, source.len(), params);
        self.done
    }

    /// The Gauss-Newton update after a complete pass; true when finished.
    fn update(&mut self, lin: &Linearization, source_len: usize, params: &GicpParams) -> bool {
        let out = &mut self.out;
        out.iterations += 1;
        out.inliers = lin.inliers;
        out.fitness = if lin.inliers > 0 {
            (lin.sum_dist_sq / lin.inliers as f64).sqrt()
        } else {
            0.0
        };
        out.inlier_fraction = lin.inliers as f64 / source_len as f64;
        out.hessian = lin.h;
        out.plane_information = params.surface_information.then_some(lin.hn);
        if lin.inliers == 0 {
            return true;
        }
        let damped = lin.h + Matrix6::identity() * params.damping;
        let Some(chol) = damped.cholesky() else {
            return true;
        };
        let delta = -chol.solve(&lin.b);
        if !delta.iter().all(|v| v.is_finite()) {
            return true;
        }
        self.tf = perturb(&self.tf, &delta);
        out.transform = self.tf;
        let dt = delta.fixed_rows::<3>(0).norm();
        let dphi = delta.fixed_rows::<3>(3).norm();
        if dt < params.translation_eps_m && dphi < params.rotation_eps_rad {
            out.converged = true;
            return true;
        }
        out.iterations >= params.max_iterations
    }
}
