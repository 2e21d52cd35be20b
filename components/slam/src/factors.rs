//! Pose-graph variables and factors: each factor gives a whitened residual
//! and its Jacobians with respect to the tangent `[dt; phi]` of each of its
//! variables (see [`crate::lie`] for the convention).

use nalgebra::{Matrix3, Matrix6, SMatrix, SVector, Vector3};

use crate::lie::{log_so3, right_jacobian_inv, skew, Pose};

/// What a variable is: which tangent directions it has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarKind {
    /// A rigid pose, 6 degrees of freedom.
    Pose3,
    /// A planar pose (x, y, heading): 2D graphs.
    Pose2,
    /// A rotation only.
    Rotation,
    /// A rotation about the body x and y axes only: the IMU-to-LiDAR bias,
    /// whose rotation about gravity no inclination can observe.
    Tilt,
}

impl VarKind {
    /// Indices into the 6-vector `[dt; phi]` that this kind moves along.
    pub fn columns(self) -> &'static [usize] {
        match self {
            VarKind::Pose3 => &[0, 1, 2, 3, 4, 5],
            VarKind::Pose2 => &[0, 1, 5],
            VarKind::Rotation => &[3, 4, 5],
            VarKind::Tilt => &[3, 4],
        }
    }
    pub fn dim(self) -> usize {
        self.columns().len()
    }
}

/// One state of the graph.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Var {
    pub pose: Pose,
    pub kind: VarKind,
    /// Held constant (the gauge, or a frozen keyframe).
    pub fixed: bool,
    /// Rigidly attached to another variable: not a state of its own, its
    /// pose follows the parent's (see [`Rigid`]).
    pub rigid: Option<Rigid>,
}

/// A pose held at a fixed offset from a parent pose of the same kind:
/// `pose = parent.pose * offset`. Old keyframes grouped this way into
/// sub-maps keep every factor while the system shrinks to one block per
/// group, so later loop closures can still bend the old trajectory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    pub parent: usize,
    pub offset: Pose,
}

/// Down-weighting of large residuals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Robust {
    None,
    /// Cauchy kernel with scale `c` (in whitened units): rho(s) = c^2 ln(1 + s/c^2).
    Cauchy(f64),
}

impl Robust {
    /// Cost of a squared whitened residual norm `s`.
    pub fn rho(self, s: f64) -> f64 {
        match self {
            Robust::None => s,
            Robust::Cauchy(c) => c * c * (s / (c * c)).ln_1p(),
        }
    }
    /// IRLS weight rho'(s).
    pub fn weight(self, s: f64) -> f64 {
        match self {
            Robust::None => 1.0,
            Robust::Cauchy(c) => 1.0 / (1.0 + s / (c * c)),
        }
    }
}

/// A measurement between variables. Factors live inline in a preallocated
/// vector (boxing the large variant would allocate per factor).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Factor {
    /// Relative pose `z ~ x_i^-1 x_j` with an information matrix over
    /// `[t; rotation vector]` (geodesic rotation error). `sqrt_info` is the
    /// upper factor `U` with `info = U^T U`.
    Between {
        i: usize,
        j: usize,
        z: Pose,
        sqrt_info: Matrix6<f64>,
        robust: Robust,
    },
    /// The SE-Sync (chordal) cost of a relative pose:
    /// `kappa |R_j - R_i R_z|_F^2 + tau |t_j - t_i - R_i t_z|^2`.
    Chordal {
        i: usize,
        j: usize,
        z: Pose,
        kappa: f64,
        tau: f64,
    },
    /// Gravity seen by the IMU (paper eq. 5-7): the unit "up" vector measured
    /// in the IMU frame against `B^T R_i^T e_z`, where `B` is the IMU-to-body
    /// bias rotation. Residual on the tangent plane of the measurement.
    Inclination {
        pose: usize,
        bias: usize,
        up: Vector3<f64>,
        /// 1 / standard deviation of the direction, 1/rad.
        sqrt_weight: f64,
    },
    /// A soft prior on a variable's rotation: `Log(R_prior^T R_i)`.
    RotationPrior {
        i: usize,
        r: Matrix3<f64>,
        sqrt_weight: f64,
    },
    /// Holds a pose's position and heading (the gauge of a gravity-aligned
    /// map: roll and pitch stay free for the inclination factors).
    Anchor {
        i: usize,
        position: Vector3<f64>,
        yaw: f64,
        sqrt_weight: f64,
    },
}

/// Largest residual and number of variables of any factor.
pub const MAX_ROWS: usize = 12;
pub type Residual = SVector<f64, MAX_ROWS>;
pub type Jacobian = SMatrix<f64, MAX_ROWS, 6>;

/// A factor linearised at the current state (unweighted by any robust kernel).
#[derive(Clone, Copy, Debug)]
pub struct Linearized {
    pub rows: usize,
    pub r: Residual,
    pub vars: [usize; 2],
    pub nvars: usize,
    pub j: [Jacobian; 2],
}

impl Factor {
    pub fn vars(&self) -> ([usize; 2], usize) {
        match *self {
            Factor::Between { i, j, .. } | Factor::Chordal { i, j, .. } => ([i, j], 2),
            Factor::Inclination { pose, bias, .. } => ([pose, bias], 2),
            Factor::Anchor { i, .. } | Factor::RotationPrior { i, .. } => ([i, i], 1),
        }
    }

    pub fn robust(&self) -> Robust {
        match *self {
            Factor::Between { robust, .. } => robust,
            _ => Robust::None,
        }
    }

    /// Whitened residual only (cheaper than [`Factor::linearize`]).
    pub fn residual(&self, vars: &[Var]) -> (Residual, usize) {
        let l = self.evaluate(vars, false);
        (l.r, l.rows)
    }

    /// The factor's cost contribution (robust kernel applied).
    pub fn cost(&self, vars: &[Var]) -> f64 {
        let (r, _) = self.residual(vars);
        self.robust().rho(r.norm_squared())
    }

    /// The second-order term `sum_k r_k d2 r_k` of the chordal cost, which
    /// Gauss-Newton leaves out: nonzero only in the rotation blocks of each
    /// variable (the residuals are linear in translations and separable in
    /// the two rotations). With it the step is Newton's, which matters on
    /// badly conditioned graphs where Gauss-Newton converges only linearly.
    /// Returns the 3x3 rotation blocks for `i` and `j`.
    pub fn curvature(&self, vars: &[Var]) -> Option<[Matrix3<f64>; 2]> {
        let Factor::Chordal {
            i,
            j,
            z,
            kappa,
            tau,
        } = *self
        else {
            return None;
        };
        let (xi, xj) = (&vars[i].pose, &vars[j].pose);
        let d_r = xj.r - xi.r * z.r;
        let d_t = xj.t - xi.t - xi.r * z.t;
        let mut si = Matrix3::zeros();
        let mut sj = Matrix3::zeros();
        for a in 0..3 {
            for b in a..3 {
                // sym(G_a G_b) with G = [e]x: (e_b e_a^T + e_a e_b^T)/2 - delta_ab I.
                let mut m = Matrix3::zeros();
                m[(b, a)] += 0.5;
                m[(a, b)] += 0.5;
                if a == b {
                    m -= Matrix3::identity();
                }
                let vj = kappa * d_r.dot(&(xj.r * m));
                let vi = -kappa * d_r.dot(&(xi.r * m * z.r)) - tau * d_t.dot(&(xi.r * m * z.t));
                sj[(a, b)] = vj;
                sj[(b, a)] = vj;
                si[(a, b)] = vi;
                si[(b, a)] = vi;
            }
        }
        Some([si, sj])
    }

    pub fn linearize(&self, vars: &[Var]) -> Linearized {
        self.evaluate(vars, true)
    }

    fn evaluate(&self, vars: &[Var], jac: bool) -> Linearized {
        let (v, nvars) = self.vars();
        let mut out = Linearized {
            rows: 0,
            r: Residual::zeros(),
            vars: v,
            nvars,
            j: [Jacobian::zeros(); 2],
        };
        match *self {
            Factor::Between {
                i, j, z, sqrt_info, ..
            } => between(&vars[i].pose, &vars[j].pose, &z, &sqrt_info, jac, &mut out),
            Factor::Chordal {
                i,
                j,
                z,
                kappa,
                tau,
            } => chordal(&vars[i].pose, &vars[j].pose, &z, kappa, tau, jac, &mut out),
            Factor::Inclination {
                pose,
                bias,
                up,
                sqrt_weight,
            } => inclination(
                &vars[pose].pose,
                &vars[bias].pose,
                &up,
                sqrt_weight,
                jac,
                &mut out,
            ),
            Factor::Anchor {
                i,
                position,
                yaw,
                sqrt_weight,
            } => anchor(&vars[i].pose, &position, yaw, sqrt_weight, jac, &mut out),
            Factor::RotationPrior { i, r, sqrt_weight } => {
                let e = log_so3(&(r.transpose() * vars[i].pose.r));
                out.rows = 3;
                out.r.fixed_rows_mut::<3>(0).copy_from(&(e * sqrt_weight));
                if jac {
                    let j = right_jacobian_inv(&e) * sqrt_weight;
                    out.j[0].fixed_view_mut::<3, 3>(0, 3).copy_from(&j);
                }
            }
        }
        out
    }
}

fn between(xi: &Pose, xj: &Pose, z: &Pose, u: &Matrix6<f64>, jac: bool, out: &mut Linearized) {
    let rit = xi.r.transpose();
    let zrt = z.r.transpose();
    let v = rit * (xj.t - xi.t);
    let e_t = zrt * (v - z.t);
    let rij = rit * xj.r;
    let e_r = log_so3(&(zrt * rij));
    let mut e = SVector::<f64, 6>::zeros();
    e.fixed_rows_mut::<3>(0).copy_from(&e_t);
    e.fixed_rows_mut::<3>(3).copy_from(&e_r);
    out.rows = 6;
    out.r.fixed_rows_mut::<6>(0).copy_from(&(u * e));
    if !jac {
        return;
    }
    let jinv = right_jacobian_inv(&e_r);
    let mut ji = Matrix6::<f64>::zeros();
    ji.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-zrt * rit));
    ji.fixed_view_mut::<3, 3>(0, 3).copy_from(&(zrt * skew(&v)));
    ji.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(-jinv * rij.transpose()));
    let mut jj = Matrix6::<f64>::zeros();
    jj.fixed_view_mut::<3, 3>(0, 0).copy_from(&(zrt * rit));
    jj.fixed_view_mut::<3, 3>(3, 3).copy_from(&jinv);
    out.j[0].fixed_view_mut::<6, 6>(0, 0).copy_from(&(u * ji));
    out.j[1].fixed_view_mut::<6, 6>(0, 0).copy_from(&(u * jj));
}

fn chordal(xi: &Pose, xj: &Pose, z: &Pose, kappa: f64, tau: f64, jac: bool, out: &mut Linearized) {
    let (sk, st) = (kappa.sqrt(), tau.sqrt());
    let d_r = xj.r - xi.r * z.r;
    let d_t = xj.t - xi.t - xi.r * z.t;
    out.rows = 12;
    for (k, x) in d_r.iter().enumerate() {
        out.r[k] = sk * x;
    }
    for k in 0..3 {
        out.r[9 + k] = st * d_t[k];
    }
    if !jac {
        return;
    }
    for k in 0..3 {
        let mut ek = Vector3::zeros();
        ek[k] = 1.0;
        let gk = skew(&ek);
        let di = -(xi.r * gk * z.r) * sk;
        let dj = (xj.r * gk) * sk;
        for (row, (a, b)) in di.iter().zip(dj.iter()).enumerate() {
            out.j[0][(row, 3 + k)] = *a;
            out.j[1][(row, 3 + k)] = *b;
        }
    }
    let rt = xi.r * skew(&z.t) * st;
    for a in 0..3 {
        out.j[0][(9 + a, a)] = -st;
        out.j[1][(9 + a, a)] = st;
        for b in 0..3 {
            out.j[0][(9 + a, 3 + b)] = rt[(a, b)];
        }
    }
}

/// An orthonormal basis (as rows) of the plane orthogonal to unit `u`.
fn tangent_basis(u: &Vector3<f64>) -> SMatrix<f64, 2, 3> {
    let helper = if u.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let a = u.cross(&helper).normalize();
    let b = u.cross(&a);
    SMatrix::<f64, 2, 3>::from_rows(&[a.transpose(), b.transpose()])
}

fn inclination(x: &Pose, bias: &Pose, up: &Vector3<f64>, w: f64, jac: bool, out: &mut Linearized) {
    let n = tangent_basis(up) * w;
    let world_up_in_body = x.r.transpose() * Vector3::z();
    let pred = bias.r.transpose() * world_up_in_body;
    out.rows = 2;
    out.r.fixed_rows_mut::<2>(0).copy_from(&(n * pred));
    if !jac {
        return;
    }
    let jp = n * bias.r.transpose() * skew(&world_up_in_body);
    let jb = n * skew(&pred);
    out.j[0].fixed_view_mut::<2, 3>(0, 3).copy_from(&jp);
    out.j[1].fixed_view_mut::<2, 3>(0, 3).copy_from(&jb);
}

fn wrap_angle(a: f64) -> f64 {
    let two_pi = 2.0 * core::f64::consts::PI;
    a - two_pi * ((a + core::f64::consts::PI) / two_pi).floor()
}

fn anchor(x: &Pose, p: &Vector3<f64>, yaw: f64, w: f64, jac: bool, out: &mut Linearized) {
    out.rows = 4;
    let d = (x.t - p) * w;
    out.r.fixed_rows_mut::<3>(0).copy_from(&d);
    out.r[3] = wrap_angle(x.yaw() - yaw) * w;
    if !jac {
        return;
    }
    for a in 0..3 {
        out.j[0][(a, a)] = w;
    }
    // d yaw / d phi_k with R <- R Exp(phi): dR = R [e_k]x.
    let (r00, r10) = (x.r[(0, 0)], x.r[(1, 0)]);
    let den = (r00 * r00 + r10 * r10).max(1e-12);
    for k in 0..3 {
        let mut ek = Vector3::zeros();
        ek[k] = 1.0;
        let dr: Matrix3<f64> = x.r * skew(&ek);
        out.j[0][(3, 3 + k)] = w * (r00 * dr[(1, 0)] - r10 * dr[(0, 0)]) / den;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lie::exp_so3;

    fn var(kind: VarKind, phi: [f64; 3], t: [f64; 3]) -> Var {
        Var {
            pose: Pose::new(exp_so3(&Vector3::from(phi)), Vector3::from(t)),
            kind,
            fixed: false,
            rigid: None,
        }
    }

    /// Every factor's Jacobian against central differences along each
    /// tangent direction of each of its variables.
    fn check(f: &Factor, vars: &[Var]) {
        let lin = f.linearize(vars);
        let h = 1e-6;
        for slot in 0..lin.nvars {
            let vi = lin.vars[slot];
            for c in 0..6 {
                let mut d = [0.0; 6];
                d[c] = h;
                let step = |s: f64| {
                    let mut vs = vars.to_vec();
                    let dt = Vector3::new(d[0], d[1], d[2]) * s;
                    let phi = Vector3::new(d[3], d[4], d[5]) * s;
                    vs[vi].pose = vs[vi].pose.retract(&dt, &phi);
                    f.residual(&vs).0
                };
                let num = (step(1.0) - step(-1.0)) / (2.0 * h);
                for row in 0..lin.rows {
                    let a = lin.j[slot][(row, c)];
                    assert!(
                        (num[row] - a).abs() < 1e-5 * (1.0 + a.abs()),
                        "{f:?} var {slot} col {c} row {row}: numeric {} analytic {a}",
                        num[row]
                    );
                }
            }
        }
    }

    fn sample_vars() -> Vec<Var> {
        vec![
            var(VarKind::Pose3, [0.1, -0.2, 0.7], [1.0, 2.0, 0.5]),
            var(VarKind::Pose3, [-0.3, 0.25, 1.9], [3.0, 1.0, -0.2]),
            var(VarKind::Rotation, [0.02, -0.03, 0.01], [0.0; 3]),
        ]
    }

    fn sqrt_info() -> Matrix6<f64> {
        let mut u = Matrix6::identity() * 3.0;
        u[(0, 1)] = 0.5;
        u[(2, 4)] = -0.7;
        u[(3, 5)] = 0.2;
        u
    }

    #[test]
    fn between_jacobians_match_numeric() {
        let z = Pose::new(
            exp_so3(&Vector3::new(0.2, 0.1, 1.0)),
            Vector3::new(1.5, -0.5, 0.3),
        );
        check(
            &Factor::Between {
                i: 0,
                j: 1,
                z,
                sqrt_info: sqrt_info(),
                robust: Robust::None,
            },
            &sample_vars(),
        );
    }

    #[test]
    fn chordal_jacobians_match_numeric() {
        let z = Pose::new(
            exp_so3(&Vector3::new(0.2, 0.1, 1.0)),
            Vector3::new(1.5, -0.5, 0.3),
        );
        check(
            &Factor::Chordal {
                i: 0,
                j: 1,
                z,
                kappa: 7.0,
                tau: 3.0,
            },
            &sample_vars(),
        );
    }

    #[test]
    fn inclination_jacobians_match_numeric() {
        check(
            &Factor::Inclination {
                pose: 1,
                bias: 2,
                up: Vector3::new(0.1, -0.2, 1.0).normalize(),
                sqrt_weight: 50.0,
            },
            &sample_vars(),
        );
    }

    #[test]
    fn anchor_jacobians_match_numeric() {
        check(
            &Factor::Anchor {
                i: 1,
                position: Vector3::new(2.0, 1.0, 0.0),
                yaw: 0.3,
                sqrt_weight: 100.0,
            },
            &sample_vars(),
        );
    }

    #[test]
    fn rotation_prior_jacobian_matches_numeric() {
        check(
            &Factor::RotationPrior {
                i: 2,
                r: exp_so3(&Vector3::new(0.05, 0.0, -0.02)),
                sqrt_weight: 10.0,
            },
            &sample_vars(),
        );
    }

    #[test]
    fn exact_measurements_give_zero_residuals() {
        let vars = sample_vars();
        let z = vars[0].pose.between(&vars[1].pose);
        for f in [
            Factor::Between {
                i: 0,
                j: 1,
                z,
                sqrt_info: sqrt_info(),
                robust: Robust::Cauchy(1.0),
            },
            Factor::Chordal {
                i: 0,
                j: 1,
                z,
                kappa: 1.0,
                tau: 1.0,
            },
            Factor::Inclination {
                pose: 0,
                bias: 2,
                up: vars[2].pose.r.transpose() * vars[0].pose.r.transpose() * Vector3::z(),
                sqrt_weight: 1.0,
            },
        ] {
            assert!(f.cost(&vars) < 1e-20, "{f:?}");
        }
    }
}
