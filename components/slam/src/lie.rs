//! Rotations and rigid transforms as the factors need them: `Pose` keeps a
//! rotation matrix (no quaternion renormalisation between iterations),
//! `exp`/`log` of SO(3) and the inverse right Jacobian.
//!
//! Perturbation convention everywhere in this crate: a pose moves by
//! `R <- R Exp(phi)` (body-frame rotation) and `t <- t + dt` (world-frame
//! translation); a tangent vector is ordered `[dt; phi]`.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// `[v]x`, the matrix of the cross product with `v`.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Exponential map of SO(3) (Rodrigues), exact to first order near zero.
pub fn exp_so3(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta2 = phi.norm_squared();
    let k = skew(phi);
    let (a, b) = if theta2 < 1e-10 {
        (1.0 - theta2 / 6.0, 0.5 - theta2 / 24.0)
    } else {
        let theta = theta2.sqrt();
        (theta.sin() / theta, (1.0 - theta.cos()) / theta2)
    };
    Matrix3::identity() + k * a + k * k * b
}

/// Logarithm of SO(3): the rotation vector of `r`, angle in [0, pi].
pub fn log_so3(r: &Matrix3<f64>) -> Vector3<f64> {
    // The quaternion route is stable near 0 and near pi alike.
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r));
    let q = if q.w < 0.0 {
        UnitQuaternion::new_unchecked(-q.into_inner())
    } else {
        q
    };
    let v = q.imag();
    let s = v.norm();
    if s < 1e-12 {
        // sin(theta/2) ~ theta/2: phi = 2 v / w.
        return v * (2.0 / q.w);
    }
    let theta = 2.0 * s.atan2(q.w);
    v * (theta / s)
}

/// Inverse of the right Jacobian of SO(3): `Log(Exp(phi) Exp(d)) ~ phi + Jr^-1(phi) d`.
pub fn right_jacobian_inv(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta2 = phi.norm_squared();
    let k = skew(phi);
    let c = if theta2 < 1e-10 {
        1.0 / 12.0 + theta2 / 720.0
    } else {
        let theta = theta2.sqrt();
        1.0 / theta2 - (1.0 + theta.cos()) / (2.0 * theta * theta.sin())
    };
    Matrix3::identity() + k * 0.5 + k * k * c
}

/// Project a near-rotation onto SO(3) (nearest in Frobenius norm).
pub fn project_so3(m: &Matrix3<f64>) -> Matrix3<f64> {
    let svd = m.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return Matrix3::identity();
    };
    let mut d = Matrix3::identity();
    if (u * vt).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    u * d * vt
}

/// A rigid transform kept as a rotation matrix and a translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub r: Matrix3<f64>,
    pub t: Vector3<f64>,
}

impl Default for Pose {
    fn default() -> Self {
        Pose::identity()
    }
}

impl Pose {
    pub fn identity() -> Self {
        Pose {
            r: Matrix3::identity(),
            t: Vector3::zeros(),
        }
    }

    pub fn new(r: Matrix3<f64>, t: Vector3<f64>) -> Self {
        Pose { r, t }
    }

    /// A planar pose (x, y, heading) embedded in 3D.
    pub fn planar(x: f64, y: f64, theta: f64) -> Self {
        let (s, c) = theta.sin_cos();
        Pose {
            r: Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
            t: Vector3::new(x, y, 0.0),
        }
    }

    pub fn from_isometry(iso: &Isometry3<f64>) -> Self {
        Pose {
            r: *iso.rotation.to_rotation_matrix().matrix(),
            t: iso.translation.vector,
        }
    }

    pub fn to_isometry(&self) -> Isometry3<f64> {
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(self.r));
        Isometry3::from_parts(Translation3::from(self.t), q)
    }

    pub fn inverse(&self) -> Pose {
        let rt = self.r.transpose();
        Pose {
            r: rt,
            t: -(rt * self.t),
        }
    }

    /// `self * other`.
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose {
            r: self.r * other.r,
            t: self.r * other.t + self.t,
        }
    }

    /// `self^-1 * other`, the pose of `other` seen from `self`.
    pub fn between(&self, other: &Pose) -> Pose {
        let rt = self.r.transpose();
        Pose {
            r: rt * other.r,
            t: rt * (other.t - self.t),
        }
    }

    pub fn transform(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.r * p + self.t
    }

    /// Apply a tangent step `[dt; phi]` (see the module's convention).
    pub fn retract(&self, dt: &Vector3<f64>, phi: &Vector3<f64>) -> Pose {
        Pose {
            r: self.r * exp_so3(phi),
            t: self.t + dt,
        }
    }

    /// Heading of the body x axis in the world x-y plane, rad.
    pub fn yaw(&self) -> f64 {
        self.r[(1, 0)].atan2(self.r[(0, 0)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_log_round_trip_from_zero_to_near_pi() {
        for phi in [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1e-9, -2e-9, 3e-9),
            Vector3::new(0.3, -0.2, 0.1),
            Vector3::new(0.0, 0.0, 3.1),
            Vector3::new(1.0, 2.0, -1.5).normalize() * (std::f64::consts::PI - 1e-5),
        ] {
            let back = log_so3(&exp_so3(&phi));
            assert!((back - phi).norm() < 1e-9, "{phi} -> {back}");
        }
    }

    #[test]
    fn inverse_right_jacobian_matches_numeric() {
        let phi = Vector3::new(0.4, -0.7, 0.2);
        let jinv = right_jacobian_inv(&phi);
        let h = 1e-6;
        for k in 0..3 {
            let mut d = Vector3::zeros();
            d[k] = h;
            let num = (log_so3(&(exp_so3(&phi) * exp_so3(&d))) - phi) / h;
            assert!((num - jinv.column(k)).norm() < 1e-5, "{k}: {num}");
        }
    }

    #[test]
    fn between_inverts_compose() {
        let a = Pose::new(
            exp_so3(&Vector3::new(0.1, 0.2, 0.3)),
            Vector3::new(1.0, 2.0, 3.0),
        );
        let b = Pose::new(
            exp_so3(&Vector3::new(-0.3, 0.1, 0.9)),
            Vector3::new(-1.0, 0.5, 0.0),
        );
        let c = a.compose(&a.between(&b));
        assert!((c.r - b.r).norm() < 1e-12 && (c.t - b.t).norm() < 1e-12);
        assert!((Pose::planar(0.0, 0.0, 2.5).yaw() - 2.5).abs() < 1e-12);
    }
}
