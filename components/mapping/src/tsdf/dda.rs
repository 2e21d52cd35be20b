//! Voxel traversal of a segment (Amanatides and Woo 1987): every voxel the
//! segment passes through, in order, each once.

use crate::floor_i32;

/// The voxels a segment crosses, in voxel units: voxel `i` spans
/// `[i, i + 1)` on each axis. An iterator of integer voxel coordinates from
/// the voxel of `start` to the voxel of `end`.
///
/// The count is fixed up front (one voxel plus one per boundary crossed
/// on each axis), and an axis stops stepping once it reaches the end
/// voxel's coordinate, so the walk always ends in the end voxel after
/// exactly that many voxels, whatever the rounding. The caller keeps the
/// coordinates finite and well inside the `i32` range; a non-finite
/// endpoint gives an empty walk.
#[derive(Clone, Debug)]
pub struct VoxelRay {
    // Per axis as plain fields, not arrays indexed by the axis: the
    // compiler then keeps the whole walk in registers.
    x: i32,
    y: i32,
    z: i32,
    /// Ray parameter (0 at start, 1 at end) of the next boundary per axis;
    /// infinite once the axis has no boundary left to cross.
    tx: f64,
    ty: f64,
    tz: f64,
    x_axis: Axis,
    y_axis: Axis,
    z_axis: Axis,
    remaining: u32,
}

/// The fixed part of the walk along one axis.
#[derive(Clone, Copy, Debug, Default)]
struct Axis {
    step: i32,
    t_delta: f64,
    /// Boundaries still to cross.
    left: u32,
}

impl Axis {
    /// The walk along one axis from `s` to `e`: the start voxel, the
    /// parameter of the first boundary and the fixed part.
    #[inline(always)]
    fn new(s: f64, e: f64) -> (i32, f64, Axis) {
        let (v0, v1) = (floor_i32(s), floor_i32(e));
        let left = v1.abs_diff(v0);
        if left == 0 {
            return (v0, f64::INFINITY, Axis::default());
        }
        let d = e - s;
        let (step, first, dist) = if d > 0.0 {
            (1, v0 as f64 + 1.0 - s, d)
        } else {
            (-1, s - v0 as f64, -d)
        };
        // Capped: a segment a few subnormals long must not give an
        // infinite step (0 * inf would be NaN and break the walk).
        let inv = (1.0 / dist).min(f64::MAX);
        (
            v0,
            first * inv,
            Axis {
                step,
                t_delta: inv,
                left,
            },
        )
    }

    /// Moves one voxel along the axis; returns the next boundary's
    /// parameter.
    #[inline(always)]
    fn advance(&mut self, v: &mut i32, t: f64) -> f64 {
        *v += self.step;
        self.left = self.left.saturating_sub(1);
        if self.left == 0 {
            f64::INFINITY
        } else {
            t + self.t_delta
        }
    }
}

impl VoxelRay {
    /// The walk from `start` to `end` (voxel units).
    #[inline(always)]
    pub fn new(start: [f64; 3], end: [f64; 3]) -> VoxelRay {
        if !start.iter().chain(&end).all(|v| v.is_finite()) {
            return VoxelRay {
                x: 0,
                y: 0,
                z: 0,
                tx: f64::INFINITY,
                ty: f64::INFINITY,
                tz: f64::INFINITY,
                x_axis: Axis::default(),
                y_axis: Axis::default(),
                z_axis: Axis::default(),
                remaining: 0,
            };
        }
        let (x, tx, x_axis) = Axis::new(start[0], end[0]);
        let (y, ty, y_axis) = Axis::new(start[1], end[1]);
        let (z, tz, z_axis) = Axis::new(start[2], end[2]);
        let remaining = 1u32
            .saturating_add(x_axis.left)
            .saturating_add(y_axis.left)
            .saturating_add(z_axis.left);
        VoxelRay {
            x,
            y,
            z,
            tx,
            ty,
            tz,
            x_axis,
            y_axis,
            z_axis,
            remaining,
        }
    }

    /// The walk from `start_m` to `end_m` (metres) over voxels of side
    /// `voxel_m` (voxel `i` spans `[i, i + 1) * voxel_m`).
    pub fn through(start_m: [f64; 3], end_m: [f64; 3], voxel_m: f64) -> VoxelRay {
        let k = 1.0 / voxel_m;
        VoxelRay::new(start_m.map(|v| v * k), end_m.map(|v| v * k))
    }

    /// Voxels still to come.
    pub fn remaining(&self) -> u32 {
        self.remaining
    }
}

impl Iterator for VoxelRay {
    type Item = [i32; 3];

    #[inline(always)]
    fn next(&mut self) -> Option<[i32; 3]> {
        if self.remaining == 0 {
            return None;
        }
        let out = [self.x, self.y, self.z];
        self.remaining -= 1;
        if self.remaining > 0 {
            // The axis whose boundary comes first; ties to the lower axis.
            // An axis with no boundary left has an infinite parameter and
            // another axis still has one (remaining > 0).
            if self.tx <= self.ty && self.tx <= self.tz {
                self.tx = self.x_axis.advance(&mut self.x, self.tx);
            } else if self.ty <= self.tz {
                self.ty = self.y_axis.advance(&mut self.y, self.ty);
            } else {
                self.tz = self.z_axis.advance(&mut self.z, self.tz);
            }
        }
        Some(out)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.remaining as usize;
        (n, Some(n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// SplitMix64: a tiny deterministic generator for the random rays.
    fn rng(state: &mut u64) -> f64 {
        *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let z = crate::hash::mix64(*state);
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Length of the part of segment `s..e` inside voxel `v` (slab method).
    fn inside_length(s: [f64; 3], e: [f64; 3], v: [i32; 3]) -> f64 {
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for a in 0..3 {
            let d = e[a] - s[a];
            let (lo, hi) = (v[a] as f64, v[a] as f64 + 1.0);
            if d == 0.0 {
                if s[a] < lo || s[a] >= hi {
                    return 0.0;
                }
                continue;
            }
            let (ta, tb) = ((lo - s[a]) / d, (hi - s[a]) / d);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        let len = ((e[0] - s[0]).powi(2) + (e[1] - s[1]).powi(2) + (e[2] - s[2]).powi(2)).sqrt();
        (t1 - t0).max(0.0) * len
    }

    #[test]
    fn visits_exactly_the_voxels_the_segment_crosses() {
        let mut state = 7u64;
        let samples = 100_000;
        for _ in 0..300 {
            let s: [f64; 3] = std::array::from_fn(|_| rng(&mut state) * 20.0 - 10.0);
            let e: [f64; 3] = std::array::from_fn(|a| s[a] + rng(&mut state) * 12.0 - 6.0);
            let walk: Vec<[i32; 3]> = VoxelRay::new(s, e).collect();
            let set: BTreeSet<[i32; 3]> = walk.iter().copied().collect();
            assert_eq!(set.len(), walk.len(), "a voxel visited twice");
            // Consecutive voxels are face neighbours.
            for w in walk.windows(2) {
                let d: i32 = (0..3).map(|a| (w[1][a] - w[0][a]).abs()).sum();
                assert_eq!(d, 1);
            }
            // Exactly the voxels with a part of the segment inside.
            let lo: [i32; 3] = std::array::from_fn(|a| s[a].min(e[a]).floor() as i32);
            let hi: [i32; 3] = std::array::from_fn(|a| s[a].max(e[a]).floor() as i32);
            let mut exact = BTreeSet::new();
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        if inside_length(s, e, [x, y, z]) > 1e-12 {
                            exact.insert([x, y, z]);
                        }
                    }
                }
            }
            assert_eq!(set, exact);
            // A fine sampling sees a subset, missing only slivers shorter
            // than its step.
            let mut sampled = BTreeSet::new();
            for k in 0..=samples {
                let t = k as f64 / samples as f64;
                sampled.insert(std::array::from_fn(|a| {
                    (s[a] + (e[a] - s[a]) * t).floor() as i32
                }));
            }
            assert!(sampled.is_subset(&set));
            let seg = (0..3).map(|a| (e[a] - s[a]).powi(2)).sum::<f64>().sqrt();
            for v in set.difference(&sampled) {
                assert!(inside_length(s, e, *v) < 2.0 * seg / samples as f64);
            }
        }
    }

    #[test]
    fn axis_aligned_and_degenerate_segments() {
        let w: Vec<_> = VoxelRay::new([0.5, 0.5, 0.5], [3.5, 0.5, 0.5]).collect();
        assert_eq!(w, vec![[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]);
        let w: Vec<_> = VoxelRay::new([-0.5, 0.5, 0.5], [-2.5, 0.5, 0.5]).collect();
        assert_eq!(w, vec![[-1, 0, 0], [-2, 0, 0], [-3, 0, 0]]);
        let w: Vec<_> = VoxelRay::new([1.2, 1.2, 1.2], [1.2, 1.2, 1.2]).collect();
        assert_eq!(w, vec![[1, 1, 1]]);
        assert_eq!(VoxelRay::new([f64::NAN, 0.0, 0.0], [1.0; 3]).count(), 0);
        // A boundary crossed by a subnormal length.
        let w: Vec<_> = VoxelRay::new([0.0; 3], [-5e-324, 0.0, 0.0]).collect();
        assert_eq!(w, vec![[0, 0, 0], [-1, 0, 0]]);
        let w: Vec<_> = VoxelRay::new([0.0; 3], [-5e-324, -5e-324, 1e-300]).collect();
        assert_eq!(w.len(), 3);
        assert_eq!(w[2], [-1, -1, 0]);
    }
}
