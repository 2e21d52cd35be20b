//! Voxel-grid downsampling: one centroid per occupied voxel.
//!
//! Why a hand-rolled open-addressing table rather than `HashMap`: the grid
//! runs on every scan and must not allocate once built, and its output order
//! must not depend on a per-process hasher seed. Voxels come out in the order
//! their first point arrived, so identical input gives identical output.

/// What one [`VoxelGrid::downsample`] call kept and dropped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VoxelStats {
    /// Points read from the input.
    pub input: usize,
    /// Output points (occupied voxels, or kept points without downsampling).
    pub output: usize,
    /// Points with a NaN or infinite coordinate.
    pub non_finite: usize,
    /// Points whose voxel index does not fit the 21-bit-per-axis key
    /// (more than 2^20 voxels from the origin).
    pub out_of_range: usize,
    /// Points that would have opened a voxel beyond the grid's capacity.
    pub over_capacity: usize,
}

/// Voxel indices per axis are kept in 21 bits: [-2^20, 2^20).
const AXIS_BITS: u32 = 21;
const AXIS_HALF: i64 = 1 << (AXIS_BITS - 1);
const EMPTY: u32 = u32::MAX;

/// A voxel grid with a fixed capacity of output points.
#[derive(Clone, Debug)]
pub struct VoxelGrid {
    capacity: usize,
    /// Hash table of voxel slots (index into `keys`/`sums`), `EMPTY` if free.
    /// Power-of-two length, at least twice the capacity: short probes.
    table: Vec<u32>,
    shift: u32,
    keys: Vec<u64>,
    /// Coordinate sums per voxel, then centroids after `downsample`.
    sums: Vec<[f64; 3]>,
    counts: Vec<u32>,
    /// The fill in progress (between `begin` and `finish`).
    inv: f64,
    keep_all: bool,
    stats: VoxelStats,
}

impl VoxelGrid {
    /// A grid that holds up to `max_points` output points; every buffer is
    /// allocated here and never grows.
    pub fn with_capacity(max_points: usize) -> Self {
        let max_points = max_points.min(u32::MAX as usize - 1);
        let slots = (2 * max_points).max(16).next_power_of_two();
        VoxelGrid {
            capacity: max_points,
            table: vec![EMPTY; slots],
            shift: 64 - slots.trailing_zeros(),
            keys: Vec::with_capacity(max_points),
            sums: Vec::with_capacity(max_points),
            counts: Vec::with_capacity(max_points),
            inv: 0.0,
            keep_all: true,
            stats: VoxelStats::default(),
        }
    }

    /// Maximum number of output points.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// The output of the last [`downsample`](Self::downsample).
    pub fn points(&self) -> &[[f64; 3]] {
        &self.sums
    }

    /// Replace the grid's content with the centroids of `points` per voxel of
    /// edge `voxel_m` (metres). A `voxel_m` that is not a positive finite
    /// number keeps every finite point as it is (up to the capacity).
    /// Non-finite points, points too far from the origin and points that
    /// would exceed the capacity are counted and dropped.
    pub fn downsample(
        &mut self,
        points: impl IntoIterator<Item = [f64; 3]>,
        voxel_m: f64,
    ) -> VoxelStats {
        self.begin(voxel_m);
        self.add(points);
        self.finish()
    }

    /// Start a fill in parts: [`begin`](Self::begin), any number of
    /// [`add`](Self::add), then [`finish`](Self::finish) give what one
    /// [`downsample`](Self::downsample) of all the parts in order gives, so a
    /// large cloud can be spread over bounded units of work.
    pub fn begin(&mut self, voxel_m: f64) {
        self.table.fill(EMPTY);
        self.keys.clear();
        self.sums.clear();
        self.counts.clear();
        self.stats = VoxelStats::default();
        self.keep_all = !(voxel_m.is_finite() && voxel_m > 0.0);
        self.inv = if self.keep_all { 0.0 } else { 1.0 / voxel_m };
    }

    /// Add points to the fill begun by [`begin`](Self::begin).
    pub fn add(&mut self, points: impl IntoIterator<Item = [f64; 3]>) {
        let mask = self.table.len() - 1;
        let (inv, keep_all) = (self.inv, self.keep_all);
        let st = &mut self.stats;
        for p in points {
            st.input += 1;
            if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()) {
                st.non_finite += 1;
                continue;
            }
            if keep_all {
                if self.sums.len() < self.capacity {
                    self.sums.push(p);
                } else {
                    st.over_capacity += 1;
                }
                continue;
            }
            let Some(key) = voxel_key(p, inv) else {
                st.out_of_range += 1;
                continue;
            };
            // Fibonacci hashing, then linear probing.
            let mut slot = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> self.shift) as usize;
            loop {
                let v = self.table[slot];
                if v == EMPTY {
                    if self.keys.len() < self.capacity {
                        self.table[slot] = self.keys.len() as u32;
                        self.keys.push(key);
                        self.sums.push(p);
                        self.counts.push(1);
                    } else {
                        st.over_capacity += 1;
                    }
                    break;
                }
                let v = v as usize;
                if self.keys[v] == key {
                    let s = &mut self.sums[v];
                    s[0] += p[0];
                    s[1] += p[1];
                    s[2] += p[2];
                    self.counts[v] += 1;
                    break;
                }
                slot = (slot + 1) & mask;
            }
        }
    }

    /// End the fill: sums become centroids.
    pub fn finish(&mut self) -> VoxelStats {
        if !self.keep_all {
            for (s, &n) in self.sums.iter_mut().zip(&self.counts) {
                let k = 1.0 / n as f64;
                *s = [s[0] * k, s[1] * k, s[2] * k];
            }
        }
        self.stats.output = self.sums.len();
        self.stats
    }
}

/// The voxel of `p` packed into 63 bits, or `None` out of the key's range.
fn voxel_key(p: [f64; 3], inv: f64) -> Option<u64> {
    let mut key = 0u64;
    for x in p {
        let i = (x * inv).floor();
        // The range check on the float also rejects huge values before the
        // (saturating) cast.
        if !(i >= -(AXIS_HALF as f64) && i < AXIS_HALF as f64) {
            return None;
        }
        key = (key << AXIS_BITS) | ((i as i64 + AXIS_HALF) as u64);
    }
    Some(key)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centroids_per_voxel_in_first_seen_order() {
        let mut g = VoxelGrid::with_capacity(8);
        let pts = [
            [0.1, 0.1, 0.1],
            [1.2, 0.0, 0.0],
            [0.3, 0.3, 0.3],
            [-0.1, 0.0, 0.0],
            [1.4, 0.2, 0.0],
        ];
        let st = g.downsample(pts, 1.0);
        assert_eq!(st.output, 3);
        let out = g.points();
        assert!((out[0][0] - 0.2).abs() < 1e-12 && (out[0][2] - 0.2).abs() < 1e-12);
        assert!((out[1][0] - 1.3).abs() < 1e-12 && (out[1][1] - 0.1).abs() < 1e-12);
        assert_eq!(out[2], [-0.1, 0.0, 0.0]);
    }

    #[test]
    fn drops_are_counted() {
        let mut g = VoxelGrid::with_capacity(2);
        let pts = [
            [0.0, 0.0, 0.0],
            [f64::NAN, 0.0, 0.0],
            [1e12, 0.0, 0.0],
            [5.0, 0.0, 0.0],
            [9.0, 0.0, 0.0],
            [0.5, 0.5, 0.5],
        ];
        let st = g.downsample(pts, 1.0);
        assert_eq!(
            st,
            VoxelStats {
                input: 6,
                output: 2,
                non_finite: 1,
                out_of_range: 1,
                over_capacity: 1
            }
        );
        // No downsampling: every finite point, up to the capacity.
        let st = g.downsample(pts, 0.0);
        assert_eq!((st.output, st.non_finite, st.over_capacity), (2, 1, 3));
    }
}
