//! Angles of the (w, x, y, z) orientation quaternions the pose messages
//! carry.

/// Heading (yaw about z) of a (w, x, y, z) quaternion.
pub fn yaw_of(q: [f64; 4]) -> f64 {
    let [w, x, y, z] = q;
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

/// Angle between the body's up axis and the vertical, deg.
pub fn tilt_deg_of(q: [f64; 4]) -> f64 {
    let [_, x, y, _] = q;
    (1.0 - 2.0 * (x * x + y * y))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}
