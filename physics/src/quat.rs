//! Small f64 quaternion helpers for the simulation (w, x, y, z order; a
//! quaternion maps body-frame vectors into the world). Trigonometry is
//! `libm`'s, so results repeat on every machine.

/// A unit quaternion, (w, x, y, z).
pub type Quat = [f64; 4];

pub const IDENTITY: Quat = [1.0, 0.0, 0.0, 0.0];

/// Hamilton product a * b (apply b, then a).
pub fn mul(a: &Quat, b: &Quat) -> Quat {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

pub fn conj(q: &Quat) -> Quat {
    [q[0], -q[1], -q[2], -q[3]]
}

pub fn normalise(q: &Quat) -> Quat {
    let n = libm::sqrt(q.iter().map(|c| c * c).sum::<f64>());
    if n > 0.0 && n.is_finite() {
        q.map(|c| c / n)
    } else {
        IDENTITY
    }
}

/// Rotation matrix (rows) of a unit quaternion.
pub fn matrix(q: &Quat) -> [[f64; 3]; 3] {
    let [w, x, y, z] = *q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// Rotate `v` by `q`.
pub fn rotate(q: &Quat, v: [f64; 3]) -> [f64; 3] {
    mat_mul(&matrix(q), v)
}

/// Rotate `v` by the inverse of `q` (world into body).
pub fn rotate_inv(q: &Quat, v: [f64; 3]) -> [f64; 3] {
    rotate(&conj(q), v)
}

pub fn mat_mul(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// R = Rz(yaw) Ry(pitch) Rx(roll).
pub fn from_ypr(yaw: f64, pitch: f64, roll: f64) -> Quat {
    let (sy, cy) = (libm::sin(0.5 * yaw), libm::cos(0.5 * yaw));
    let (sp, cp) = (libm::sin(0.5 * pitch), libm::cos(0.5 * pitch));
    let (sr, cr) = (libm::sin(0.5 * roll), libm::cos(0.5 * roll));
    [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]
}

/// (yaw, pitch, roll) of `q`, Z-Y-X.
pub fn to_ypr(q: &Quat) -> (f64, f64, f64) {
    let [w, x, y, z] = *q;
    let yaw = libm::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
    let pitch = libm::asin((2.0 * (w * y - z * x)).clamp(-1.0, 1.0));
    let roll = libm::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
    (yaw, pitch, roll)
}

/// Normalised linear interpolation the short way round (exact at the ends;
/// within 1e-4 rad of slerp for the small steps the sensors interpolate).
pub fn nlerp(a: &Quat, b: &Quat, t: f64) -> Quat {
    let dot: f64 = (0..4).map(|k| a[k] * b[k]).sum();
    let s = if dot < 0.0 { -1.0 } else { 1.0 };
    normalise(&[0, 1, 2, 3].map(|k| a[k] + (s * b[k] - a[k]) * t))
}

/// Rotation by `angle` about the unit `axis`.
pub fn from_axis_angle(axis: [f64; 3], angle: f64) -> Quat {
    let (s, c) = (libm::sin(0.5 * angle), libm::cos(0.5 * angle));
    [c, axis[0] * s, axis[1] * s, axis[2] * s]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ypr_round_trips_and_matches_the_matrix() {
        let q = from_ypr(0.7, -0.3, 0.2);
        let (y, p, r) = to_ypr(&q);
        assert!((y - 0.7).abs() < 1e-12 && (p + 0.3).abs() < 1e-12 && (r - 0.2).abs() < 1e-12);
        // Rz(yaw) of the x axis.
        let v = rotate(&from_ypr(0.5, 0.0, 0.0), [1.0, 0.0, 0.0]);
        assert!((v[0] - 0.5f64.cos()).abs() < 1e-12 && (v[1] - 0.5f64.sin()).abs() < 1e-12);
        let back = rotate_inv(&q, rotate(&q, [0.1, 0.2, 0.3]));
        assert!((back[2] - 0.3).abs() < 1e-12);
        let composed = mul(&from_ypr(0.2, 0.0, 0.0), &from_ypr(0.3, 0.0, 0.0));
        assert!((to_ypr(&composed).0 - 0.5).abs() < 1e-12);
    }

    #[test]
    fn nlerp_takes_the_short_way() {
        let a = from_ypr(3.1, 0.0, 0.0);
        let b = from_ypr(-3.1, 0.0, 0.0);
        let m = nlerp(&a, &b, 0.5);
        assert!((to_ypr(&m).0.abs() - core::f64::consts::PI).abs() < 1e-9);
    }
}
