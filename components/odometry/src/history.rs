//! A fixed-capacity history of timestamped poses, for deskewing: where was
//! the rover at the time of each LiDAR firing?

use nalgebra::{Isometry3, Translation3};

use crate::rot;

#[derive(Clone, Copy, Debug, PartialEq)]
struct Entry {
    time_ns: u64,
    pose: Isometry3<f64>,
}

/// The newest `capacity` poses, oldest overwritten first. Storage is
/// allocated once, by [`PoseHistory::with_capacity`]; nothing grows after.
///
/// Times are nanoseconds on the executive's clock and must increase from
/// push to push; a pose that is not newer than the newest, or not finite,
/// is refused and counted.
#[derive(Clone, Debug)]
pub struct PoseHistory {
    entries: Vec<Entry>,
    /// Index of the oldest entry.
    head: usize,
    len: usize,
    /// How far past the newest pose [`PoseHistory::at`] extrapolates, ns.
    extrapolation_ns: u64,
    refused: u64,
}

fn finite(p: &Isometry3<f64>) -> bool {
    p.translation.vector.iter().all(|v| v.is_finite())
        && p.rotation.coords.iter().all(|v| v.is_finite())
}

/// The pose a fraction `s` of the way from `a` to `b` (translation linear,
/// rotation slerp); `s` > 1 extrapolates.
fn blend(a: &Isometry3<f64>, b: &Isometry3<f64>, s: f64) -> Isometry3<f64> {
    let ta = a.translation.vector;
    let tb = b.translation.vector;
    Isometry3::from_parts(
        Translation3::from(ta + (tb - ta) * s),
        rot::slerp(&a.rotation, &b.rotation, s),
    )
}

impl PoseHistory {
    /// Room for `capacity` poses (at least 2); `at` extrapolates up to
    /// `extrapolation_ns` past the newest.
    pub fn with_capacity(capacity: usize, extrapolation_ns: u64) -> Self {
        let empty = Entry {
            time_ns: 0,
            pose: Isometry3::identity(),
        };
        PoseHistory {
            entries: vec![empty; capacity.max(2)],
            head: 0,
            len: 0,
            extrapolation_ns,
            refused: 0,
        }
    }

    pub fn capacity(&self) -> usize {
        self.entries.len()
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn extrapolation_ns(&self) -> u64 {
        self.extrapolation_ns
    }

    /// Pushes refused (not newer than the newest, or not finite).
    pub fn refused(&self) -> u64 {
        self.refused
    }

    pub fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
    }

    fn entry(&self, i: usize) -> &Entry {
        &self.entries[(self.head + i) % self.entries.len()]
    }

    /// Add the pose at `time_ns`, overwriting the oldest when full. Returns
    /// false (and counts) when refused.
    pub fn push(&mut self, time_ns: u64, pose: Isometry3<f64>) -> bool {
        let newer = self.newest().is_none_or(|(t, _)| time_ns > t);
        if !newer || !finite(&pose) {
            self.refused += 1;
            return false;
        }
        let cap = self.entries.len();
        let e = Entry { time_ns, pose };
        if self.len < cap {
            self.entries[(self.head + self.len) % cap] = e;
            self.len += 1;
        } else {
            self.entries[self.head] = e;
            self.head = (self.head + 1) % cap;
        }
        true
    }

    /// Remove the newest pose (undo the last push).
    pub fn pop_newest(&mut self) -> Option<(u64, Isometry3<f64>)> {
        let n = self.newest()?;
        self.len -= 1;
        Some(n)
    }

    pub fn newest(&self) -> Option<(u64, Isometry3<f64>)> {
        (self.len > 0).then(|| {
            let e = self.entry(self.len - 1);
            (e.time_ns, e.pose)
        })
    }

    pub fn oldest(&self) -> Option<(u64, Isometry3<f64>)> {
        (self.len > 0).then(|| {
            let e = self.entry(0);
            (e.time_ns, e.pose)
        })
    }

    /// Times of the oldest and newest poses.
    pub fn span(&self) -> Option<(u64, u64)> {
        Some((self.oldest()?.0, self.newest()?.0))
    }

    /// The stored poses, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = (u64, &Isometry3<f64>)> + '_ {
        (0..self.len).map(|i| {
            let e = self.entry(i);
            (e.time_ns, &e.pose)
        })
    }

    /// The pose at `time_ns`, interpolated between the poses either side;
    /// up to the extrapolation tolerance past the newest, extrapolated from
    /// the newest two. `None` before the oldest or further past the newest.
    pub fn at(&self, time_ns: u64) -> Option<Isometry3<f64>> {
        let (t_old, t_new) = self.span()?;
        if time_ns < t_old {
            return None;
        }
        if time_ns >= t_new {
            let (_, newest) = self.newest()?;
            if time_ns == t_new {
                return Some(newest);
            }
            if time_ns - t_new > self.extrapolation_ns {
                return None;
            }
            if self.len < 2 {
                return Some(newest);
            }
            let before = self.entry(self.len - 2);
            let s = 1.0 + (time_ns - t_new) as f64 / (t_new - before.time_ns) as f64;
            return Some(blend(&before.pose, &newest, s));
        }
        // The first entry at or after time_ns: within 1..len since
        // t_old <= time_ns < t_new.
        let (mut lo, mut hi) = (0, self.len - 1);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if self.entry(mid).time_ns < time_ns {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        let b = self.entry(lo);
        if b.time_ns == time_ns || lo == 0 {
            return Some(b.pose);
        }
        let a = self.entry(lo - 1);
        let s = (time_ns - a.time_ns) as f64 / (b.time_ns - a.time_ns) as f64;
        Some(blend(&a.pose, &b.pose, s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    fn pose(x: f64, yaw: f64) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(x, 2.0 * x, -x),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
        )
    }

    fn close(a: &Isometry3<f64>, b: &Isometry3<f64>) -> bool {
        (a.translation.vector - b.translation.vector).norm() < 1e-9
            && a.rotation.angle_to(&b.rotation) < 1e-9
    }

    #[test]
    fn interpolates_between_the_bracketing_poses() {
        let mut h = PoseHistory::with_capacity(8, 0);
        assert!(h.at(0).is_none());
        for k in 0..5u64 {
            assert!(h.push(1_000 + k * 10_000_000, pose(k as f64, 0.1 * k as f64)));
        }
        // Exactly on samples.
        assert!(close(&h.at(1_000).expect("oldest"), &pose(0.0, 0.0)));
        assert!(close(&h.at(40_001_000).expect("newest"), &pose(4.0, 0.4)));
        assert!(close(&h.at(20_001_000).expect("inner"), &pose(2.0, 0.2)));
        // A quarter of the way from sample 2 to 3.
        let p = h.at(22_501_000).expect("between");
        assert!(close(&p, &pose(2.25, 0.225)), "{p}");
        assert_eq!(h.span(), Some((1_000, 40_001_000)));
    }

    #[test]
    fn none_outside_the_span_with_a_tolerance_at_the_newest_end() {
        let mut h = PoseHistory::with_capacity(4, 3_000_000);
        h.push(10_000_000, pose(0.0, 0.0));
        // One pose: only its own time and the tolerance after it.
        assert!(close(&h.at(10_000_000).expect("only"), &pose(0.0, 0.0)));
        assert!(close(&h.at(12_000_000).expect("held"), &pose(0.0, 0.0)));
        h.push(20_000_000, pose(1.0, 0.1));
        assert!(h.at(9_999_999).is_none());
        // 2 ms past the newest: extrapolated at the last velocity.
        let p = h.at(22_000_000).expect("extrapolated");
        assert!(close(&p, &pose(1.2, 0.12)), "{p}");
        assert!(h.at(23_000_000).is_some());
        assert!(h.at(23_000_001).is_none());
        assert!(h.at(u64::MAX).is_none());
    }

    #[test]
    fn capacity_wraps_overwriting_the_oldest() {
        let mut h = PoseHistory::with_capacity(3, 0);
        for k in 0..10u64 {
            h.push(k * 100, pose(k as f64, 0.0));
            assert_eq!(h.len(), (k as usize + 1).min(3));
        }
        assert_eq!(h.capacity(), 3);
        assert_eq!(h.span(), Some((700, 900)));
        assert!(h.at(699).is_none());
        assert!(close(&h.at(750).expect("in span"), &pose(7.5, 0.0)));
        assert!(close(&h.at(900).expect("newest"), &pose(9.0, 0.0)));
        let times: Vec<u64> = h.iter().map(|(t, _)| t).collect();
        assert_eq!(times, [700, 800, 900]);
        // Undo the last push.
        assert_eq!(h.pop_newest().map(|(t, _)| t), Some(900));
        assert_eq!(h.span(), Some((700, 800)));
        assert!(h.at(850).is_none());
    }

    #[test]
    fn refuses_old_repeated_and_non_finite_poses() {
        let mut h = PoseHistory::with_capacity(4, 0);
        assert!(h.push(100, pose(0.0, 0.0)));
        assert!(!h.push(100, pose(1.0, 0.0)));
        assert!(!h.push(50, pose(1.0, 0.0)));
        assert!(!h.push(200, pose(f64::NAN, 0.0)));
        let mut bad = pose(1.0, 0.0);
        bad.rotation =
            UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0));
        assert!(!h.push(200, bad));
        assert_eq!(h.refused(), 4);
        assert_eq!(h.len(), 1);
        h.clear();
        assert!(h.is_empty() && h.at(100).is_none());
    }

    #[test]
    fn interpolation_takes_the_short_way_round() {
        let mut h = PoseHistory::with_capacity(4, 0);
        let pi = core::f64::consts::PI;
        h.push(0, pose(0.0, pi - 0.1));
        h.push(100, pose(0.0, -pi + 0.1));
        let p = h.at(50).expect("between");
        let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), pi);
        assert!(p.rotation.angle_to(&q) < 1e-9, "{p}");
    }
}
