//! The volume: parameters, integration along rays, statistics.

use super::blocks::{
    block_of, local_index, BlockStore, Voxel, BLOCK_RANGE, BLOCK_SIDE, BLOCK_VOXELS,
};
use super::dda::VoxelRay;
use crate::{floor_i32, ParamsError};

/// Blocks a volume may hold (16 GiB of voxels): keeps pool indices in
/// `u32` and the table size from overflowing.
pub const MAX_BLOCKS: usize = 1 << 22;
/// Truncation distances above this many voxels are refused (every ray
/// would walk thousands of voxels).
pub const MAX_TRUNCATION_VOXELS: f64 = 1000.0;
/// Points and origins farther than this many voxels from the map origin
/// on any axis are out of range: the rays' voxels then stay inside the
/// block coordinates' 21 bits.
const MAX_VOXEL_COORD: f64 = (BLOCK_RANGE as f64) * (BLOCK_SIDE as f64) * 0.5;

/// Voxel updates one ray buffers (a ray within the truncation band
/// crosses at most about 15 voxels at the default 3 voxels).
const UPDATES: usize = 32;

/// The voxel updates of one ray, found but not yet applied: pool slots
/// (voxel index in the pool), signed distances and weights.
struct Updates {
    len: usize,
    slot: [u32; UPDATES],
    sdf: [f32; UPDATES],
    weight: [f32; UPDATES],
}

impl Updates {
    const EMPTY: Updates = Updates {
        len: 0,
        slot: [0; UPDATES],
        sdf: [0.0; UPDATES],
        weight: [0.0; UPDATES],
    };
}

/// The weight one observation gives a voxel, as a function of its signed
/// distance.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Weighting {
    /// Weight 1 everywhere (vdbfusion's default).
    #[default]
    Constant,
    /// Weight 1 in front of the surface and down to one voxel behind it,
    /// then falling linearly to 1/100 at the truncation distance: the
    /// space behind a surface is guessed, not seen.
    DropOffBehind,
}

impl Weighting {
    #[inline(always)]
    fn weight(self, sdf: f64, voxel: f64, truncation: f64) -> f32 {
        match self {
            Weighting::Constant => 1.0,
            Weighting::DropOffBehind => {
                if sdf >= -voxel || truncation <= voxel {
                    1.0
                } else {
                    let f = (truncation + sdf) / (truncation - voxel);
                    (0.01 + 0.99 * f).clamp(0.01, 1.0) as f32
                }
            }
        }
    }
}

/// Settings of a TSDF volume.
#[derive(Clone, Debug, PartialEq)]
pub struct TsdfParams {
    /// Voxel side (m).
    pub voxel_size_m: f64,
    /// Truncation distance in voxels (at most [`MAX_TRUNCATION_VOXELS`]):
    /// each ray updates the voxels within this many voxel sizes of its
    /// point, before and behind.
    pub truncation_voxels: f64,
    /// Blocks of 8x8x8 voxels (4 KiB each) in the pool (at most
    /// [`MAX_BLOCKS`]); when they are all in use, updates of voxels in new
    /// blocks are dropped and counted.
    pub max_blocks: usize,
    pub weighting: Weighting,
    /// Meshing uses only voxels whose weight is above this (0: every
    /// observed voxel).
    pub min_weight: f32,
}

impl Default for TsdfParams {
    fn default() -> Self {
        TsdfParams {
            voxel_size_m: 0.05,
            truncation_voxels: 3.0,
            max_blocks: 16_384,
            weighting: Weighting::Constant,
            min_weight: 0.0,
        }
    }
}

/// What one integration did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IntegrateStats {
    /// Points offered.
    pub points: u64,
    /// Points whose ray was walked.
    pub integrated: u64,
    /// NaN or infinite points (or origin), skipped.
    pub non_finite: u64,
    /// Points at the origin (no direction), skipped.
    pub zero_range: u64,
    /// Points (or an origin) too far from the map origin to index, skipped.
    pub out_of_range: u64,
    /// Voxel updates made.
    pub voxel_updates: u64,
    /// Voxel updates dropped: their block was new and the pool full.
    pub dropped_updates: u64,
}

/// The volume's state and totals since construction or the last
/// [`TsdfVolume::clear`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TsdfStats {
    /// Blocks in use.
    pub blocks: usize,
    /// Capacity in blocks.
    pub max_blocks: usize,
    /// Every block is in use: updates in new blocks are being dropped.
    pub full: bool,
    pub points: u64,
    pub integrated: u64,
    pub non_finite: u64,
    pub zero_range: u64,
    pub out_of_range: u64,
    pub voxel_updates: u64,
    pub dropped_updates: u64,
    /// Bytes of the fixed buffers (taken at construction, never grown).
    pub memory_bytes: usize,
}

/// A TSDF volume of fixed capacity; see the [module documentation](super).
pub struct TsdfVolume {
    params: TsdfParams,
    voxel: f64,
    inv_voxel: f64,
    truncation: f64,
    pub(crate) store: BlockStore,
    totals: IntegrateStats,
}

impl TsdfVolume {
    /// Takes all the memory the volume will ever use. Fails only on a
    /// non-positive voxel size, a negative or huge truncation or a pool
    /// over [`MAX_BLOCKS`]; a zero pool gives a volume that drops (and
    /// counts) every update.
    pub fn new(params: TsdfParams) -> Result<TsdfVolume, ParamsError> {
        if !(params.voxel_size_m.is_finite() && params.voxel_size_m > 0.0) {
            return Err(ParamsError::NotPositive("voxel_size_m"));
        }
        let t = params.truncation_voxels;
        if !(t.is_finite() && t >= 0.0) {
            return Err(ParamsError::Negative("truncation_voxels"));
        }
        if t > MAX_TRUNCATION_VOXELS {
            return Err(ParamsError::TooLarge("truncation_voxels"));
        }
        if params.max_blocks > MAX_BLOCKS {
            return Err(ParamsError::TooLarge("max_blocks"));
        }
        let truncation = t * params.voxel_size_m;
        Ok(TsdfVolume {
            voxel: params.voxel_size_m,
            inv_voxel: 1.0 / params.voxel_size_m,
            truncation,
            store: BlockStore::new(params.max_blocks),
            totals: IntegrateStats::default(),
            params,
        })
    }

    pub fn params(&self) -> &TsdfParams {
        &self.params
    }

    /// Voxel side (m).
    pub fn voxel_size(&self) -> f64 {
        self.voxel
    }

    /// Truncation distance (m).
    pub fn truncation(&self) -> f64 {
        self.truncation
    }

    /// Integrates one scan: `points` and the sensor `origin` in the map
    /// frame. For each point, the voxels its ray crosses between
    /// `depth - truncation` (not before the origin) and `depth +
    /// truncation` are updated. Allocates nothing.
    pub fn integrate(&mut self, origin: [f64; 3], points: &[[f64; 3]]) -> IntegrateStats {
        let mut s = IntegrateStats {
            points: points.len() as u64,
            ..IntegrateStats::default()
        };
        let inv_h = self.inv_voxel;
        if !origin.iter().all(|v| v.is_finite()) {
            s.non_finite = s.points;
        } else if !origin.iter().all(|v| (v * inv_h).abs() < MAX_VOXEL_COORD) {
            s.out_of_range = s.points;
        } else {
            // The block of the previous voxel, kept from ray to ray:
            // a ray stays in one or two blocks, and its neighbours often
            // in the same ones.
            let mut cache = ([i32::MIN; 3], None);
            // Software pipeline: ray k is walked (its voxels found and
            // their cache lines requested) before ray k - 1's voxels are
            // updated, so the memory fetches of one overlap the other's
            // arithmetic. Updates keep the rays' order: same results.
            let (mut a, mut b) = (Updates::EMPTY, Updates::EMPTY);
            let (mut this, mut prev) = (&mut a, &mut b);
            for p in points {
                self.walk(origin, *p, &mut cache, this, prev, &mut s);
                self.apply(prev, &mut s);
                std::mem::swap(&mut this, &mut prev);
            }
            self.apply(prev, &mut s);
        }
        self.add_totals(&s);
        s
    }

    /// Finds the voxels of the ray to `p` and their new samples into
    /// `this` (empty on entry). Should a ray have more voxels than a
    /// buffer holds, `prev` and then the full buffer are applied first.
    #[inline(always)]
    fn walk(
        &mut self,
        o: [f64; 3],
        p: [f64; 3],
        cache: &mut ([i32; 3], Option<u32>),
        this: &mut Updates,
        prev: &mut Updates,
        s: &mut IntegrateStats,
    ) {
        let (h, inv_h, delta) = (self.voxel, self.inv_voxel, self.truncation);
        let d = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        let depth = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if !depth.is_finite() {
            s.non_finite += 1;
            return;
        }
        if depth == 0.0 {
            s.zero_range += 1;
            return;
        }
        if !p.iter().all(|v| (v * inv_h).abs() < MAX_VOXEL_COORD) {
            s.out_of_range += 1;
            return;
        }
        s.integrated += 1;
        let inv_depth = 1.0 / depth;
        let dir = d.map(|c| c * inv_depth);
        let (t0, t1) = ((depth - delta).max(0.0), depth + delta);
        let start = std::array::from_fn(|a| (o[a] + dir[a] * t0) * inv_h);
        let end = std::array::from_fn(|a| (o[a] + dir[a] * t1) * inv_h);
        // Depth of voxel v's centre along the ray: v . hd + c0.
        let hd = dir.map(|c| c * h);
        let c0 = (0..3).map(|a| (0.5 * h - o[a]) * dir[a]).sum::<f64>();
        let weighting = self.params.weighting;
        for v in VoxelRay::new(start, end) {
            let b = block_of(v);
            if b != cache.0 {
                *cache = (b, self.store.get_or_insert(b));
            }
            let Some(n) = cache.1 else {
                s.dropped_updates += 1;
                continue;
            };
            let proj = v[0] as f64 * hd[0] + v[1] as f64 * hd[1] + v[2] as f64 * hd[2] + c0;
            let sdf = (depth - proj).clamp(-delta, delta);
            if this.len == UPDATES {
                self.apply(prev, s);
                self.apply(this, s);
            }
            let slot = self.store.voxel_slot(n, local_index(v));
            self.store.prefetch(slot);
            this.slot[this.len] = slot as u32;
            this.sdf[this.len] = sdf as f32;
            this.weight[this.len] = weighting.weight(sdf, h, delta);
            this.len += 1;
        }
    }

    /// Applies and empties `u`.
    #[inline(always)]
    fn apply(&mut self, u: &mut Updates, s: &mut IntegrateStats) {
        for k in 0..u.len {
            let vx = self.store.voxel_mut(u.slot[k] as usize);
            let (sdf, w) = (u.sdf[k], u.weight[k]);
            let total = vx.weight + w;
            vx.tsdf = (vx.tsdf * vx.weight + sdf * w) / total;
            vx.weight = total;
        }
        s.voxel_updates += u.len as u64;
        u.len = 0;
    }

    fn add_totals(&mut self, s: &IntegrateStats) {
        let t = &mut self.totals;
        t.points += s.points;
        t.integrated += s.integrated;
        t.non_finite += s.non_finite;
        t.zero_range += s.zero_range;
        t.out_of_range += s.out_of_range;
        t.voxel_updates += s.voxel_updates;
        t.dropped_updates += s.dropped_updates;
    }

    /// The voxel containing map point `p` (saturating far from the origin).
    pub fn voxel_of(&self, p: [f64; 3]) -> [i32; 3] {
        p.map(|c| floor_i32(c * self.inv_voxel))
    }

    /// Centre of voxel `v` in the map frame.
    pub fn voxel_center(&self, v: [i32; 3]) -> [f64; 3] {
        v.map(|c| (c as f64 + 0.5) * self.voxel)
    }

    /// Voxel `v`, if its block is allocated (its weight is 0 if never
    /// observed).
    pub fn voxel(&self, v: [i32; 3]) -> Option<Voxel> {
        let n = self.store.get(block_of(v))?;
        Some(self.store.block(n)[local_index(v)])
    }

    /// Where voxel `v` sits in the pool, if its block is allocated: an
    /// index below [`slots`](Self::slots), stable until
    /// [`clear`](Self::clear), for values kept beside the voxels.
    pub fn voxel_slot(&self, v: [i32; 3]) -> Option<usize> {
        let n = self.store.get(block_of(v))?;
        Some(self.store.voxel_slot(n, local_index(v)))
    }

    /// Voxel slots in the pool (allocated or not).
    pub fn slots(&self) -> usize {
        self.store.max_blocks() * BLOCK_VOXELS
    }

    /// Slots of the blocks allocated since the last clear: every
    /// [`voxel_slot`](Self::voxel_slot) is below it.
    pub fn slots_used(&self) -> usize {
        self.store.used() * BLOCK_VOXELS
    }

    /// Writes voxel `v` directly (tests of the meshing).
    #[cfg(test)]
    pub(crate) fn set_voxel(&mut self, v: [i32; 3], value: Voxel) -> bool {
        match self.store.get_or_insert(block_of(v)) {
            Some(n) => {
                self.store.block_mut(n)[local_index(v)] = value;
                true
            }
            None => false,
        }
    }

    /// Coordinates of the allocated blocks (voxel `v` is in block
    /// `v >> 3`), in allocation order.
    pub fn blocks(&self) -> &[[i32; 3]] {
        self.store.coords()
    }

    /// Forgets every voxel and the totals, keeping the memory (for a
    /// re-integration of every keyframe after a loop closure).
    pub fn clear(&mut self) {
        self.store.clear();
        self.totals = IntegrateStats::default();
    }

    pub fn stats(&self) -> TsdfStats {
        let t = &self.totals;
        TsdfStats {
            blocks: self.store.used(),
            max_blocks: self.store.max_blocks(),
            full: self.store.used() >= self.store.max_blocks(),
            points: t.points,
            integrated: t.integrated,
            non_finite: t.non_finite,
            zero_range: t.zero_range,
            out_of_range: t.out_of_range,
            voxel_updates: t.voxel_updates,
            dropped_updates: t.dropped_updates,
            memory_bytes: self.store.memory_bytes(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ray_along_x_writes_the_projective_distance() {
        let mut v = TsdfVolume::new(TsdfParams {
            voxel_size_m: 0.1,
            truncation_voxels: 3.0,
            ..TsdfParams::default()
        })
        .expect("valid params");
        let s = v.integrate([0.05, 0.05, 0.05], &[[1.05, 0.05, 0.05]]);
        // [0.75, 1.35] along x from 0.05: voxels 7..=13.
        assert_eq!(s.voxel_updates, 7);
        for i in 7..=13 {
            let vx = v.voxel([i, 0, 0]).expect("block");
            let expected = (1.0 - i as f64 * 0.1).clamp(-0.3, 0.3) as f32;
            assert!((vx.tsdf - expected).abs() < 1e-6, "{i}: {vx:?}");
            assert_eq!(vx.weight, 1.0);
        }
        assert_eq!(v.voxel([6, 0, 0]).map(|x| x.weight), Some(0.0));
        assert_eq!(v.voxel([15, 0, 0]).map(|x| x.weight), Some(0.0));
        assert_eq!(v.voxel([20, 0, 0]), None);
    }

    #[test]
    fn drop_off_weighs_less_behind_the_surface() {
        let w = Weighting::DropOffBehind;
        assert_eq!(w.weight(0.1, 0.05, 0.15), 1.0);
        assert_eq!(w.weight(-0.05, 0.05, 0.15), 1.0);
        assert!((w.weight(-0.15, 0.05, 0.15) - 0.01).abs() < 1e-6);
        assert!(w.weight(-0.1, 0.05, 0.15) < 1.0);
    }

    #[test]
    fn bad_parameters_are_refused() {
        for h in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let p = TsdfParams {
                voxel_size_m: h,
                ..TsdfParams::default()
            };
            assert!(TsdfVolume::new(p).is_err());
        }
        for t in [-1.0, f64::NAN, 1e6] {
            let p = TsdfParams {
                truncation_voxels: t,
                ..TsdfParams::default()
            };
            assert!(TsdfVolume::new(p).is_err());
        }
    }
}
