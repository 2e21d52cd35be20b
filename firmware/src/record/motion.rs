//! Where the rover is, as ROS 2 messages: odometry (`nav_msgs/Odometry` on
//! `/odom`), the SLAM pose (`/slam/pose`), and the frame tree on `/tf` and
//! `/tf_static` (map -> odom -> base_link -> sensors).

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};

use crate::record::cdr::CdrWriter;
use crate::record::ros2::{
    header, pose, pose_stamped, tf_message, unknown_covariance, vector3, Transform,
};
use crate::record::{RecorderTap, Topic};

/// A position and (w, x, y, z) rotation as an isometry.
pub fn isometry(position: [f64; 3], [w, x, y, z]: [f64; 4]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(Vector3::from(position)),
        UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)),
    )
}

/// An isometry as a translation and a (w, x, y, z) rotation.
pub fn parts(p: &Isometry3<f64>) -> ([f64; 3], [f64; 4]) {
    let q = p.rotation;
    (p.translation.vector.into(), [q.w, q.i, q.j, q.k])
}

/// Body-frame velocity (linear, angular) between two poses `dt_s` apart.
pub fn body_velocity(
    from: &Isometry3<f64>,
    to: &Isometry3<f64>,
    dt_s: f64,
) -> ([f64; 3], [f64; 3]) {
    if dt_s <= 0.0 {
        return ([0.0; 3], [0.0; 3]);
    }
    let step = from.inverse() * to;
    let linear = step.translation.vector / dt_s;
    let angular = step.rotation.scaled_axis() / dt_s;
    (linear.into(), angular.into())
}

/// `/tf_static`: base_link to the LiDAR (its mount: translation and
/// (w, x, y, z) rotation) and to the IMU (the odometry takes the IMU's axes
/// as the body's).
pub(crate) fn emit_fixed_frames(
    tap: &mut RecorderTap,
    (frame, now): (u64, u64),
    (lidar_xyz, lidar_q): ([f64; 3], [f64; 4]),
) {
    let stamp = tap.time(now);
    let fixed = [
        Transform {
            stamp,
            parent: "base_link",
            child: "lidar",
            translation: lidar_xyz,
            rotation: lidar_q,
        },
        Transform {
            stamp,
            parent: "base_link",
            child: "imu",
            translation: [0.0; 3],
            rotation: [1.0, 0.0, 0.0, 0.0],
        },
    ];
    tap.emit(Topic::TfStatic, frame, now, now, |w| tf_message(w, &fixed));
}

/// `/odom` with the body `velocity` (linear, angular), and odom ->
/// base_link on `/tf`.
pub(crate) fn emit_odometry(
    tap: &mut RecorderTap,
    (frame, now, stamp_ns): (u64, u64, u64),
    (position, orientation): ([f64; 3], [f64; 4]),
    (linear, angular): ([f64; 3], [f64; 3]),
) {
    let stamp = tap.time(stamp_ns);
    tap.emit(Topic::Odom, frame, now, stamp_ns, |w| {
        let mut c = CdrWriter::new(w)?;
        header(&mut c, stamp, "odom")?;
        c.string("base_link")?;
        pose(&mut c, position, orientation)?;
        unknown_covariance(&mut c, 36)?;
        vector3(&mut c, linear)?;
        vector3(&mut c, angular)?;
        unknown_covariance(&mut c, 36)
    });
    let tf = Transform {
        stamp,
        parent: "odom",
        child: "base_link",
        translation: position,
        rotation: orientation,
    };
    tap.emit(Topic::Tf, frame, now, stamp_ns, |w| tf_message(w, &[tf]));
}

/// `/slam/pose` (base_link in map) and map -> odom on `/tf`: the SLAM pose
/// composed with the inverse of the odometry pose it was computed from.
pub(crate) fn emit_slam_pose(
    tap: &mut RecorderTap,
    (frame, now, stamp_ns): (u64, u64, u64),
    map_base: ([f64; 3], [f64; 4]),
    odom_base: Option<([f64; 3], [f64; 4])>,
) {
    let stamp = tap.time(stamp_ns);
    let (position, orientation) = map_base;
    tap.emit(Topic::SlamPose, frame, now, stamp_ns, |w| {
        pose_stamped(w, stamp, "map", position, orientation)
    });
    let Some((p, q)) = odom_base else {
        return;
    };
    let map_odom = isometry(position, orientation) * isometry(p, q).inverse();
    let (translation, rotation) = parts(&map_odom);
    let tf = Transform {
        stamp,
        parent: "map",
        child: "odom",
        translation,
        rotation,
    };
    tap.emit(Topic::Tf, frame, now, stamp_ns, |w| tf_message(w, &[tf]));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_turn_and_a_step_forward_give_the_body_velocity() {
        let from = isometry([1.0, 2.0, 0.0], [1.0, 0.0, 0.0, 0.0]);
        // A quarter turn left and 0.5 m along the body's x, over 0.5 s.
        let half = std::f64::consts::FRAC_PI_4;
        let to = from * isometry([0.5, 0.0, 0.0], [half.cos(), 0.0, 0.0, half.sin()]);
        let (v, w) = body_velocity(&from, &to, 0.5);
        assert!((v[0] - 1.0).abs() < 1e-12 && v[1].abs() < 1e-12, "{v:?}");
        assert!((w[2] - std::f64::consts::PI).abs() < 1e-12, "{w:?}");
        assert_eq!(body_velocity(&from, &to, 0.0), ([0.0; 3], [0.0; 3]));
    }
}
