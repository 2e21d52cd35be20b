//! The report's `slam` section: what the SLAM task built and, in
//! simulation, how far its keyframes are from the ground truth.

use serde::Serialize;
use speleo_slam::graph_slam::{GraphSlam, SlamStats};

/// Ground-truth poses (world frame) by executive time, one per frame:
/// position and orientation (w, x, y, z).
pub struct TruthTrack {
    pub samples: Vec<(u64, [f64; 3], [f64; 4])>,
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

    /// Interpolated pose at `t_ns` (linear position, normalised linear
    /// quaternion: frames are 10 ms apart), `None` outside the track.
    fn at(&self, t_ns: u64) -> Option<([f64; 3], [f64; 4])> {
        let i = self.samples.partition_point(|s| s.0 <= t_ns);
        if i == 0 || i >= self.samples.len() {
            return None;
        }
        let (t0, a, qa) = self.samples[i - 1];
        let (t1, b, mut qb) = self.samples[i];
        let f = (t_ns - t0) as f64 / (t1 - t0).max(1) as f64;
        if (0..4).map(|k| qa[k] * qb[k]).sum::<f64>() < 0.0 {
            qb = qb.map(|c| -c);
        }
        let q = [0, 1, 2, 3].map(|k| qa[k] + f * (qb[k] - qa[k]));
        let n = q.iter().map(|c| c * c).sum::<f64>().sqrt().max(1e-12);
        Some((
            [0, 1, 2].map(|k| a[k] + f * (b[k] - a[k])),
            q.map(|c| c / n),
        ))
    }
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct SlamFigures {
    pub keyframes: usize,
    pub loop_closures: u64,
    pub loop_candidates_rejected: u64,
    pub registrations: u64,
    pub registrations_rejected: u64,
    /// Registrations that kept the odometry's guess along a direction
    /// their surfaces did not hold (a bare plane's x, y and yaw).
    pub registrations_unheld: u64,
    pub lm_iterations: u64,
    pub grouped_keyframes: u64,
    /// Loop closures added from outside the pipeline (injected faults).
    pub external_loop_closures: u64,
    pub keyframes_refused: u64,
    pub scans_busy: u64,
    /// Scan points beyond a keyframe's voxel capacity.
    pub scan_points_dropped: u64,
    /// Angle of the estimated IMU-to-LiDAR bias rotation.
    pub bias_deg: f64,
    /// The odometry's distance scale learned from the registrations.
    pub odometry_scale: f64,
    /// Against ground truth (simulation only): keyframe positions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ate_mean_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ate_max_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub altitude_err_mean_m: Option<f64>,
    /// The same after the best rigid alignment of the keyframe positions
    /// onto the truth (what trajectory evaluation tools report by default).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ate_aligned_mean_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ate_aligned_max_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub altitude_err_aligned_mean_m: Option<f64>,
    /// Tilt between the estimated bias and the simulated IMU misalignment.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_error_deg: Option<f64>,
    /// Keyframe poses in the world frame (simulation) or the map frame,
    /// with the true pose at the same time where known: for `--trajectory`.
    #[serde(skip)]
    pub trajectory: Vec<KeyframeTrajectory>,
}

/// One keyframe: when, where SLAM put it and where it truly was.
#[derive(Clone, Copy, Debug)]
pub struct KeyframeTrajectory {
    pub stamp_ns: u64,
    pub position: [f64; 3],
    /// Orientation, (w, x, y, z).
    pub orientation: [f64; 4],
    pub truth: Option<([f64; 3], [f64; 4])>,
    /// The wheel/IMU odometry's pose at the keyframe, in the same frame:
    /// what the scans corrected (on a garage's bare roof, where they see
    /// only a plane, SLAM parted from the odometry, which read the truth).
    pub odometry: ([f64; 3], [f64; 4]),
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
        registrations_unheld: s.registrations_unheld,
        lm_iterations: s.lm_iterations,
        grouped_keyframes: s.grouped,
        external_loop_closures: s.external_loop_closures,
        keyframes_refused: s.keyframes_refused,
        scans_busy: s.scans_busy,
        scan_points_dropped: s.scan_points_dropped,
        bias_deg: angle(&b),
        odometry_scale: slam.odometry_scale(),
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
    // The map frame is the odometry frame; in simulation it sits at the
    // first true pose, level, heading as the rover heads.
    let (origin, yaw) = truth.and_then(|t| t.odom_origin).unwrap_or(([0.0; 3], 0.0));
    let world_from_map = nalgebra::Isometry3::from_parts(
        nalgebra::Translation3::from(nalgebra::Vector3::from(origin)),
        nalgebra::UnitQuaternion::from_euler_angles(0.0, 0.0, yaw),
    );
    let mut errs = Vec::new();
    let mut alt = Vec::new();
    let mut pairs = Vec::new();
    for (k, kf) in slam.keyframes().iter().enumerate() {
        let est = world_from_map * slam.keyframe_pose(k).to_isometry();
        let q = est.rotation.into_inner();
        let odom = world_from_map * kf.odom.to_isometry();
        let qo = odom.rotation.into_inner();
        let truth = truth
            .filter(|t| t.odom_origin.is_some())
            .and_then(|t| t.at(kf.stamp_ns));
        f.trajectory.push(KeyframeTrajectory {
            stamp_ns: kf.stamp_ns,
            position: est.translation.vector.into(),
            orientation: [q.w, q.i, q.j, q.k],
            truth,
            odometry: (odom.translation.vector.into(), [qo.w, qo.i, qo.j, qo.k]),
        });
        let Some((t, _)) = truth else { continue };
        let d = est.translation.vector - nalgebra::Vector3::from(t);
        errs.push(d.norm());
        alt.push(d.z.abs());
        pairs.push((est.translation.vector, nalgebra::Vector3::from(t)));
    }
    if !errs.is_empty() {
        let n = errs.len() as f64;
        f.ate_mean_m = Some(errs.iter().sum::<f64>() / n);
        f.ate_max_m = Some(errs.iter().fold(0.0, |m: f64, e| m.max(*e)));
        f.altitude_err_mean_m = Some(alt.iter().sum::<f64>() / n);
    }
    if let Some(align) = rigid_alignment(&pairs) {
        let d: Vec<_> = pairs
            .iter()
            .map(|(e, t)| align.transform_point(&(*e).into()).coords - t)
            .collect();
        let n = d.len() as f64;
        f.ate_aligned_mean_m = Some(d.iter().map(|v| v.norm()).sum::<f64>() / n);
        f.ate_aligned_max_m = Some(d.iter().map(|v| v.norm()).fold(0.0, f64::max));
        f.altitude_err_aligned_mean_m = Some(d.iter().map(|v| v.z.abs()).sum::<f64>() / n);
    }
    f
}

/// The rotation and translation that best map the estimated positions onto
/// the true ones in the least-squares sense (Umeyama 1991, without scale),
/// as trajectory evaluation tools align before comparing. `None` for fewer
/// than three pairs.
fn rigid_alignment(
    pairs: &[(nalgebra::Vector3<f64>, nalgebra::Vector3<f64>)],
) -> Option<nalgebra::Isometry3<f64>> {
    use nalgebra::{Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
    if pairs.len() < 3 {
        return None;
    }
    let n = pairs.len() as f64;
    let ce = pairs.iter().map(|p| p.0).sum::<Vector3<f64>>() / n;
    let ct = pairs.iter().map(|p| p.1).sum::<Vector3<f64>>() / n;
    let h: Matrix3<f64> = pairs
        .iter()
        .map(|(e, t)| (t - ct) * (e - ce).transpose())
        .sum();
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let sign = (u * v_t).determinant().signum();
    let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, sign)) * v_t;
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Some(nalgebra::Isometry3::from_parts(
        Translation3::from(ct - rot * ce),
        rot,
    ))
}

/// Writes the keyframe trajectory in the TUM format (`time x y z qx qy qz
/// qw`, seconds) to `path`, the odometry's poses at the same times beside
/// it (`NAME.odom.EXT`) and, where the truth is known, the true poses
/// (`NAME.truth.EXT`), ready for trajectory evaluation tools.
pub fn write_tum(path: &std::path::Path, rows: &[KeyframeTrajectory]) -> std::io::Result<()> {
    use std::io::Write;
    let line = |w: &mut dyn Write, t: u64, p: [f64; 3], q: [f64; 4]| {
        writeln!(
            w,
            "{:.9} {:.6} {:.6} {:.6} {:.9} {:.9} {:.9} {:.9}",
            t as f64 * 1e-9,
            p[0],
            p[1],
            p[2],
            q[1],
            q[2],
            q[3],
            q[0]
        )
    };
    let mut est = std::io::BufWriter::new(std::fs::File::create(path)?);
    for r in rows {
        line(&mut est, r.stamp_ns, r.position, r.orientation)?;
    }
    est.flush()?;
    let beside = |kind: &str| {
        let stem = path
            .file_stem()
            .map_or("trajectory".into(), |s| s.to_string_lossy());
        let name = match path.extension() {
            Some(e) => format!("{stem}.{kind}.{}", e.to_string_lossy()),
            None => format!("{stem}.{kind}"),
        };
        path.with_file_name(name)
    };
    let mut odom = std::io::BufWriter::new(std::fs::File::create(beside("odom"))?);
    for r in rows {
        line(&mut odom, r.stamp_ns, r.odometry.0, r.odometry.1)?;
    }
    odom.flush()?;
    if rows.iter().any(|r| r.truth.is_some()) {
        let mut gt = std::io::BufWriter::new(std::fs::File::create(beside("truth"))?);
        for r in rows {
            if let Some((p, q)) = r.truth {
                line(&mut gt, r.stamp_ns, p, q)?;
            }
        }
        gt.flush()?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::rigid_alignment;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

    #[test]
    fn the_alignment_undoes_a_known_rigid_motion() {
        let truth: Vec<Vector3<f64>> = (0..20)
            .map(|k| {
                let s = k as f64;
                Vector3::new(s, 0.3 * (0.5 * s).sin(), 0.02 * s * s)
            })
            .collect();
        let moved = Isometry3::from_parts(
            Translation3::new(1.0, -2.0, 0.5),
            UnitQuaternion::from_euler_angles(0.01, -0.02, 0.3),
        );
        let pairs: Vec<_> = truth
            .iter()
            .map(|t| (moved.transform_point(&(*t).into()).coords, *t))
            .collect();
        let a = rigid_alignment(&pairs).expect("three or more pairs");
        for (e, t) in &pairs {
            let d = (a.transform_point(&(*e).into()).coords - t).norm();
            assert!(d < 1e-9, "{d}");
        }
        assert!(rigid_alignment(&pairs[..2]).is_none());
    }
}
