//! The keyframes' clouds for mapping and their current poses, shared on the
//! bus: the `slam` task writes each keyframe's deskewed revolution and,
//! after every optimisation, every keyframe's pose; the `maps` task and the
//! mesh builder read them. Maps are made from these, not from the SLAM's
//! registration clouds (0.2 m voxels, too coarse for 5 cm surfaces), so a
//! pose-graph correction re-projects every point.
//!
//! Points are kept in the base frame as 16-bit integers of 2 mm (the
//! HDL-32E's own distance unit), and the intensity of each return: 7
//! bytes a point, +-65 m. All storage is taken at start-up.

use speleo_slam::lie::Pose;

/// Metres per integer unit.
pub const LSB_M: f64 = 0.002;
/// Largest coordinate that fits, m.
pub const MAX_COORD_M: f64 = i16::MAX as f64 * LSB_M;

pub struct KeyframeClouds {
    per_keyframe: usize,
    points: Vec<[i16; 3]>,
    /// Each point's return intensity (0: none measured).
    intensities: Vec<u8>,
    counts: Vec<u32>,
    /// Map <- base of each keyframe, as last optimised.
    poses: Vec<Pose>,
    /// Keyframes whose clouds are complete.
    len: usize,
    /// Points written into the keyframe being staged.
    staged: usize,
    /// Bumped every time the poses are replaced.
    generation: u64,
    /// Points that did not fit (beyond the coordinate range, or the
    /// keyframe's capacity, or a store already full).
    pub dropped: u64,
    /// Keyframes refused because the store was full.
    pub refused: u64,
}

impl KeyframeClouds {
    pub fn new(keyframes: usize, per_keyframe: usize) -> Self {
        KeyframeClouds {
            per_keyframe,
            points: vec![[0; 3]; keyframes * per_keyframe],
            intensities: vec![0; keyframes * per_keyframe],
            counts: vec![0; keyframes],
            poses: Vec::with_capacity(keyframes),
            len: 0,
            staged: 0,
            generation: 0,
            dropped: 0,
            refused: 0,
        }
    }

    pub fn capacity(&self) -> usize {
        self.counts.len()
    }

    pub fn per_keyframe(&self) -> usize {
        self.per_keyframe
    }

    /// Keyframes with a complete cloud.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn memory_bytes(&self) -> usize {
        self.points.len() * 7 + self.counts.len() * 4 + self.poses.capacity() * 96
    }

    /// Start staging the next keyframe's cloud (any earlier staging is
    /// dropped). False when the store is full.
    pub fn begin(&mut self) -> bool {
        self.staged = 0;
        if self.len >= self.capacity() {
            self.refused += 1;
            return false;
        }
        true
    }

    /// Add a point (base frame, m) to the staged cloud, its intensity
    /// not measured.
    pub fn push(&mut self, p: [f64; 3]) {
        self.push_return(p, 0);
    }

    /// Add a point (base frame, m) and its return's intensity to the
    /// staged cloud.
    pub fn push_return(&mut self, p: [f64; 3], intensity: u8) {
        let fits = p.iter().all(|c| c.abs() <= MAX_COORD_M);
        if self.len >= self.capacity() || self.staged >= self.per_keyframe || !fits {
            self.dropped += 1;
            return;
        }
        let q = p.map(|c| (c / LSB_M).round() as i16);
        let i = self.len * self.per_keyframe + self.staged;
        self.points[i] = q;
        self.intensities[i] = intensity;
        self.staged += 1;
    }

    /// The staged cloud becomes keyframe `len()`.
    pub fn commit(&mut self) {
        if self.len < self.capacity() {
            self.counts[self.len] = self.staged as u32;
            self.len += 1;
        }
        self.staged = 0;
    }

    /// Keyframe `k`'s cloud (base frame, m), point by point.
    pub fn cloud(&self, k: usize) -> impl ExactSizeIterator<Item = [f64; 3]> + '_ {
        let n = self.counts.get(k).copied().unwrap_or(0) as usize;
        let start = k.min(self.capacity()) * self.per_keyframe;
        self.points[start..start + n]
            .iter()
            .map(|q| q.map(|c| c as f64 * LSB_M))
    }

    /// Up to `n` of keyframe `k`'s points from point `from`, and the
    /// cloud's size.
    pub fn cloud_part(
        &self,
        k: usize,
        from: usize,
        n: usize,
    ) -> (impl Iterator<Item = [f64; 3]> + '_, usize) {
        let total = self.counts.get(k).copied().unwrap_or(0) as usize;
        let start = k.min(self.capacity()) * self.per_keyframe;
        let (a, b) = (from.min(total), from.saturating_add(n).min(total));
        let part = self.points[start + a..start + b]
            .iter()
            .map(|q| q.map(|c| c as f64 * LSB_M));
        (part, total)
    }

    /// The intensities of the points [`cloud_part`](Self::cloud_part)
    /// gives for the same arguments.
    pub fn intensity_part(&self, k: usize, from: usize, n: usize) -> &[u8] {
        let total = self.counts.get(k).copied().unwrap_or(0) as usize;
        let start = k.min(self.capacity()) * self.per_keyframe;
        let (a, b) = (from.min(total), from.saturating_add(n).min(total));
        &self.intensities[start + a..start + b]
    }

    /// Replace the poses (map <- base, keyframe order); a pose for a
    /// keyframe whose cloud is missing is kept for when it arrives.
    pub fn set_poses(&mut self, poses: impl IntoIterator<Item = Pose>) {
        self.poses.clear();
        for p in poses {
            if self.poses.len() == self.poses.capacity() {
                break;
            }
            self.poses.push(p);
        }
        self.generation += 1;
    }

    /// Keyframe `k`'s pose, once optimised.
    pub fn pose(&self, k: usize) -> Option<&Pose> {
        self.poses.get(k)
    }

    /// Keyframes that have both a cloud and a pose.
    pub fn ready(&self) -> usize {
        self.len.min(self.poses.len())
    }

    pub fn generation(&self) -> u64 {
        self.generation
    }
}

impl speleo_slam::staging::MapSink for KeyframeClouds {
    fn begin(&mut self) -> bool {
        KeyframeClouds::begin(self)
    }

    fn push(&mut self, p: [f64; 3], intensity: u8) {
        KeyframeClouds::push_return(self, p, intensity)
    }

    fn commit(&mut self) {
        KeyframeClouds::commit(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    #[test]
    fn each_point_keeps_its_returns_intensity() {
        let mut s = KeyframeClouds::new(2, 4);
        assert!(s.begin());
        s.push_return([1.0, 0.0, 0.0], 25);
        s.push([2.0, 0.0, 0.0]);
        s.push_return([3.0, 0.0, 0.0], 60);
        s.commit();
        assert_eq!(s.intensity_part(0, 0, 10), &[25, 0, 60]);
        assert_eq!(s.intensity_part(0, 1, 1), &[0]);
        let (part, total) = s.cloud_part(0, 2, 5);
        assert_eq!((part.count(), total), (1, 3));
        assert_eq!(s.intensity_part(0, 2, 5), &[60]);
        assert!(s.intensity_part(1, 0, 5).is_empty(), "no such keyframe yet");
    }

    #[test]
    fn clouds_round_trip_at_two_millimetres_and_never_grow() {
        let mut s = KeyframeClouds::new(2, 3);
        assert!(s.begin());
        s.push([1.0, -2.0, 0.3337]);
        s.push([70.0, 0.0, 0.0]); // beyond +-65 m
        s.push([0.0, 0.0, f64::NAN]); // not finite
        s.push([0.5, 0.5, 0.5]);
        s.push([0.1, 0.1, 0.1]);
        s.push([0.2, 0.2, 0.2]); // the keyframe is full
        s.commit();
        assert_eq!(s.len(), 1);
        assert_eq!(s.dropped, 3);
        let c: Vec<_> = s.cloud(0).collect();
        assert_eq!(c.len(), 3);
        assert!((c[0][2] - 0.334).abs() < 1e-12, "{:?}", c[0]);
        assert!(s.begin());
        s.commit();
        assert!(!s.begin(), "two keyframes fill the store");
        assert_eq!(s.refused, 1);
        assert_eq!(s.ready(), 0, "no pose yet");
        s.set_poses((0..5).map(|i| Pose::new(Matrix3::identity(), Vector3::x() * i as f64)));
        assert_eq!(s.ready(), 2);
        assert_eq!(s.generation(), 1);
        assert_eq!(s.cloud(7).len(), 0);
    }
}
