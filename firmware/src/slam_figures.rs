//! The report's `slam` section: what the SLAM task built and, in
//! simulation, how far its keyframes are from the ground truth.

use serde::Serialize;
use speleo_slam::graph_slam::{GraphSlam, SlamStats};

/// Ground-truth positions (world frame) by executive time, one per frame.
pub struct TruthTrack {
    pub samples: Vec<(u64, [f64; 3])>,
    /// world <- odom: the odometry frame's origin and heading in the world.
    pub odom_origin: Option<([f64; 3], f64)>,
}

impl TruthTrack {
    pub fn with_capacity(n: usize) -> Self {
        TruthTrack {
            samples: Vec::with_capacity(n),
            odom_origin: None,
        }
    }

    /// Linear interpolation at `t_ns`, `None` outside the track.
    fn at(&self, t_ns: u64) -> Option<[f64; 3]> {
        let i = self.samples.partition_point(|s| s.0 <= t_ns);
        if i == 0 || i >= self.samples.len() {
            return None;
        }
        let (t0, a) = self.samples[i - 1];
        let (t1, b) = self.samples[i];
        let f = (t_ns - t0) as f64 / (t1 - t0).max(1) as f64;
        Some([0, 1, 2].map(|k| a[k] + f * (b[k] - a[k])))
    }
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct SlamFigures {
    pub keyframes: usize,
    pub loop_closures: u64,
    pub loop_candidates_rejected: u64,
    pub registrations: u64,
    pub registrations_rejected: u64,
    pub lm_iterations: u64,
    pub frozen_keyframes: u64,
    pub keyframes_refused: u64,
    pub scans_busy: u64,
    /// Angle of the estimated IMU-to-LiDAR bias rotation.
    pub bias_deg: f64,
    /// Against ground truth (simulation only): keyframe positions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ate_mean_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ate_max_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub altitude_err_mean_m: Option<f64>,
    /// Tilt between the estimated bias and the simulated IMU misalignment.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_error_deg: Option<f64>,
}

pub fn figures(
    slam: &GraphSlam,
    truth: Option<&TruthTrack>,
    misalignment_rpy_deg: Option<[f64; 3]>,
) -> SlamFigures {
    let s: SlamStats = slam.stats();
    let b = slam.bias();
    let angle = |m: &nalgebra::Matrix3<f64>| speleo_slam::lie::log_so3(m).norm().to_degrees();
    let mut f = SlamFigures {
        keyframes: slam.keyframes().len(),
        loop_closures: s.loop_closures,
        loop_candidates_rejected: s.loop_candidates_rejected,
        registrations: s.registrations,
        registrations_rejected: s.registrations_rejected,
        lm_iterations: s.lm_iterations,
        frozen_keyframes: s.frozen,
        keyframes_refused: s.keyframes_refused,
        scans_busy: s.scans_busy,
        bias_deg: angle(&b),
        ..SlamFigures::default()
    };
    if let Some([r, p, y]) = misalignment_rpy_deg {
        // Only the tilt is observable through gravity: compare where each
        // rotation takes "up".
        let m = nalgebra::UnitQuaternion::from_euler_angles(
            r.to_radians(),
            p.to_radians(),
            y.to_radians(),
        );
        let up_m = m.inverse() * nalgebra::Vector3::z();
        let up_b = b.transpose() * nalgebra::Vector3::z();
        f.bias_error_deg = Some(up_m.angle(&up_b).to_degrees());
    }
    let Some(track) = truth else { return f };
    let Some((origin, yaw)) = track.odom_origin else {
        return f;
    };
    let rz = nalgebra::Rotation3::from_euler_angles(0.0, 0.0, yaw);
    let mut errs = Vec::new();
    let mut alt = Vec::new();
    for (k, kf) in slam.keyframes().iter().enumerate() {
        let Some(t) = track.at(kf.stamp_ns) else {
            continue;
        };
        let est = rz * slam.keyframe_pose(k).t + nalgebra::Vector3::from(origin);
        let d = est - nalgebra::Vector3::from(t);
        errs.push(d.norm());
        alt.push(d.z.abs());
    }
    if !errs.is_empty() {
        let n = errs.len() as f64;
        f.ate_mean_m = Some(errs.iter().sum::<f64>() / n);
        f.ate_max_m = Some(errs.iter().fold(0.0, |m: f64, e| m.max(*e)));
        f.altitude_err_mean_m = Some(alt.iter().sum::<f64>() / n);
    }
    f
}
