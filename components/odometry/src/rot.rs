//! Rotation helpers with the trigonometry of `libm`, so the results are the
//! same bit for bit on every machine (the platform's libm may differ in the
//! last bit; nalgebra's own trigonometry uses it).

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// Wrap an angle to (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = 2.0 * core::f64::consts::PI;
    let w = a - two_pi * libm::floor((a + core::f64::consts::PI) / two_pi);
    if w <= -core::f64::consts::PI {
        w + two_pi
    } else {
        w
    }
}

/// The rotation by the rotation vector `v` (axis times angle, rad).
pub fn exp(v: &Vector3<f64>) -> UnitQuaternion<f64> {
    let angle = libm::sqrt(v.dot(v));
    let (w, s) = if angle < 1e-9 {
        // sin(a/2)/a ~ 1/2 - a^2/48.
        (1.0 - angle * angle / 8.0, 0.5 - angle * angle / 48.0)
    } else {
        let half = 0.5 * angle;
        (libm::cos(half), libm::sin(half) / angle)
    };
    UnitQuaternion::new_normalize(Quaternion::new(w, s * v.x, s * v.y, s * v.z))
}

/// The rotation vector of `q` (the shorter way round), rad.
pub fn log(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let (mut w, mut v) = (q.w, q.imag());
    if w < 0.0 {
        w = -w;
        v = -v;
    }
    let n = libm::sqrt(v.dot(&v));
    if n < 1e-12 {
        // angle ~ 2 n / w.
        return v * (2.0 / w.max(1e-300));
    }
    v * (2.0 * libm::atan2(n, w) / n)
}

/// Spherical interpolation from `a` (s = 0) to `b` (s = 1), the shorter way
/// round; `s` outside 0..1 extrapolates at the same rate.
pub fn slerp(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>, s: f64) -> UnitQuaternion<f64> {
    let d = a.inverse() * b;
    let r = a * exp(&(log(&d) * s));
    UnitQuaternion::new_normalize(r.into_inner())
}

/// Roll, pitch and yaw (R = Rz(yaw) Ry(pitch) Rx(roll)), rad.
pub fn to_rpy(q: &UnitQuaternion<f64>) -> (f64, f64, f64) {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    let roll = libm::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
    let pitch = libm::asin((2.0 * (w * y - z * x)).clamp(-1.0, 1.0));
    let yaw = libm::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
    (roll, pitch, yaw)
}

/// The rotation Rz(yaw) Ry(pitch) Rx(roll).
pub fn from_rpy(roll: f64, pitch: f64, yaw: f64) -> UnitQuaternion<f64> {
    let (sr, cr) = (libm::sin(0.5 * roll), libm::cos(0.5 * roll));
    let (sp, cp) = (libm::sin(0.5 * pitch), libm::cos(0.5 * pitch));
    let (sy, cy) = (libm::sin(0.5 * yaw), libm::cos(0.5 * yaw));
    UnitQuaternion::new_normalize(Quaternion::new(
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn euler_round_trip_and_agreement_with_nalgebra() {
        for &(r, p, y) in &[(0.1, -0.2, 3.0), (-1.0, 0.5, -2.5), (0.0, 0.0, 0.0)] {
            let q = from_rpy(r, p, y);
            let n = UnitQuaternion::from_euler_angles(r, p, y);
            assert!(q.angle_to(&n) < 1e-12);
            let (r2, p2, y2) = to_rpy(&q);
            assert!((r - r2).abs() < 1e-12 && (p - p2).abs() < 1e-12 && (y - y2).abs() < 1e-12);
        }
    }

    #[test]
    fn exp_log_and_slerp() {
        let v = Vector3::new(0.3, -0.2, 1.1);
        let q = exp(&v);
        assert!(q.angle_to(&UnitQuaternion::from_scaled_axis(v)) < 1e-12);
        assert!((log(&q) - v).norm() < 1e-12);
        let tiny = Vector3::new(1e-12, 0.0, -2e-12);
        assert!((log(&exp(&tiny)) - tiny).norm() < 1e-20);
        let a = from_rpy(0.0, 0.0, 0.2);
        let b = from_rpy(0.0, 0.0, 0.6);
        let (_, _, y) = to_rpy(&slerp(&a, &b, 0.25));
        assert!((y - 0.3).abs() < 1e-12);
        let (_, _, y) = to_rpy(&slerp(&a, &b, 1.5));
        assert!((y - 0.8).abs() < 1e-12);
        // The other sign of the same rotation changes nothing.
        let nb = UnitQuaternion::new_unchecked(-b.into_inner());
        let (_, _, y) = to_rpy(&slerp(&a, &nb, 0.5));
        assert!((y - 0.4).abs() < 1e-12);
    }

    #[test]
    fn wrap() {
        let pi = core::f64::consts::PI;
        assert!((wrap_angle(3.0 * pi / 2.0) + pi / 2.0).abs() < 1e-12);
        assert_eq!(wrap_angle(pi), pi);
        assert_eq!(wrap_angle(-pi), pi);
        assert!((wrap_angle(-0.5) + 0.5).abs() < 1e-15);
    }
}
