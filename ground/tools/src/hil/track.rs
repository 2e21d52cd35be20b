//! The flight binary's SLAM track against the twin's truth: both recordings
//! carry Unix times from the same machine's clock, so each `/slam/pose` is
//! compared with the truth at its own time.

use std::path::Path;

use serde::Serialize;
use speleo_firmware::record::cdr::{CdrError, CdrReader};

/// A pose's time (Unix ns) and position.
type Stamped = (u64, [f64; 3]);

/// How far the believed track lay from the true one, in the map frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrackError {
    /// SLAM poses compared (those within the truth's time span).
    pub poses: usize,
    pub mean_m: f64,
    pub p95_m: f64,
    pub max_m: f64,
}

/// The position of a `geometry_msgs/PoseStamped` and its stamp, Unix ns.
fn read_pose(b: &[u8]) -> Result<Stamped, CdrError> {
    let mut r = CdrReader::new(b)?;
    let sec = r.i32()?;
    let nsec = r.u32()?;
    r.string()?;
    let mut p = [0.0; 3];
    for v in &mut p {
        *v = f64::from_bits(r.u64()?);
    }
    let t = (sec.max(0) as u64) * 1_000_000_000 + nsec as u64;
    Ok((t, p))
}

/// Every pose on `topic` of the recording at `path`, in time order.
fn poses(path: &Path, topic: &str) -> Result<Vec<Stamped>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let stream =
        mcap::MessageStream::new(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = Vec::new();
    for m in stream {
        let m = m.map_err(|e| format!("{}: {e}", path.display()))?;
        if m.channel.topic != topic {
            continue;
        }
        let pose = read_pose(&m.data)
            .map_err(|e| format!("{}: a {topic} message: {e:?}", path.display()))?;
        out.push(pose);
    }
    out.sort_by_key(|p| p.0);
    Ok(out)
}

/// The truth at `t`, interpolated between its samples; none outside them.
fn truth_at(truth: &[Stamped], t: u64) -> Option<[f64; 3]> {
    let i = truth.partition_point(|s| s.0 < t);
    let b = truth.get(i)?;
    if b.0 == t {
        return Some(b.1);
    }
    let a = truth.get(i.checked_sub(1)?)?;
    let f = (t - a.0) as f64 / (b.0 - a.0) as f64;
    Some(core::array::from_fn(|k| a.1[k] + f * (b.1[k] - a.1[k])))
}

/// The believed positions against the truth at the same times, the truth
/// taken into the map frame (level, at the true start `start` = x, y, z,
/// yaw, heading as the rover started). None when no pose falls within the
/// truth's time span.
pub fn compare(believed: &[Stamped], truth: &[Stamped], start: [f64; 4]) -> Option<TrackError> {
    let (c, s) = (start[3].cos(), start[3].sin());
    let mut errors: Vec<f64> = believed
        .iter()
        .filter_map(|&(t, b)| {
            let p = truth_at(truth, t)?;
            let (dx, dy, dz) = (p[0] - start[0], p[1] - start[1], p[2] - start[2]);
            let m = [c * dx + s * dy, -s * dx + c * dy, dz];
            Some((0..3).map(|k| (m[k] - b[k]).powi(2)).sum::<f64>().sqrt())
        })
        .collect();
    if errors.is_empty() {
        return None;
    }
    errors.sort_by(f64::total_cmp);
    let n = errors.len();
    Some(TrackError {
        poses: n,
        mean_m: errors.iter().sum::<f64>() / n as f64,
        p95_m: errors[((n - 1) as f64 * 0.95).round() as usize],
        max_m: errors[n - 1],
    })
}

/// The flight recording's `/slam/pose` against the twin recording's
/// `/sim/ground_truth`.
pub fn track_error(
    flight: &Path,
    twin: &Path,
    start: [f64; 4],
) -> Result<Option<TrackError>, String> {
    let believed = poses(flight, "/slam/pose")?;
    let truth = poses(twin, "/sim/ground_truth")?;
    Ok(compare(&believed, &truth, start))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_truth_is_taken_at_each_pose_s_time_into_the_map_frame() {
        // The rover started at (10, 5, 1) heading +y and drove 2 m along y
        // in 2 s; the map's x is that heading.
        let start = [10.0, 5.0, 1.0, std::f64::consts::FRAC_PI_2];
        let s = 1_000_000_000u64;
        let truth: Vec<Stamped> = (0..=2)
            .map(|k| (k * s, [10.0, 5.0 + k as f64, 1.0]))
            .collect();
        let believed = vec![
            (s / 2, [0.5, 0.0, 0.0]),
            (s, [1.1, 0.0, 0.0]),
            // After the truth ends: not compared.
            (3 * s, [9.0, 9.0, 9.0]),
        ];
        let e = compare(&believed, &truth, start).expect("two poses");
        assert_eq!(e.poses, 2);
        assert!((e.max_m - 0.1).abs() < 1e-9, "{e:?}");
        assert!((e.mean_m - 0.05).abs() < 1e-9, "{e:?}");
    }

    #[test]
    fn no_pose_within_the_truth_gives_none() {
        let truth = vec![(10, [0.0; 3]), (20, [0.0; 3])];
        assert_eq!(compare(&[(30, [0.0; 3])], &truth, [0.0; 4]), None);
    }

    #[test]
    fn a_pose_message_reads_back() {
        let mut b = Vec::new();
        speleo_firmware::record::ros2::pose_stamped(
            &mut b,
            speleo_firmware::record::encode::Time::from_ns(1_767_225_600_250_000_000),
            "map",
            [1.5, -2.0, 0.25],
            [0.0, 0.0, 0.0, 1.0],
        )
        .expect("written");
        assert_eq!(
            read_pose(&b),
            Ok((1_767_225_600_250_000_000, [1.5, -2.0, 0.25]))
        );
    }
}
