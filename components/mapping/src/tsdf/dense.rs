//! The TSDF of a region as dense arrays, for checking by outside tools
//! (e.g. scikit-image's marching cubes on the same values). Allocates: a
//! tool, not for the periodic work.

use super::blocks::{block_of, local_index};
use super::volume::TsdfVolume;

/// Dense regions larger than this many voxels are refused.
const MAX_DENSE_VOXELS: usize = 1 << 28;

/// A box of voxels as dense arrays, index `(x * dims[1] + y) * dims[2] + z`
/// (C order for `numpy.reshape(dims)`): voxel `(x, y, z)` of the box has
/// its centre at `origin + (x, y, z) * voxel_size`.
#[derive(Clone, Debug, PartialEq)]
pub struct DenseGrid {
    pub dims: [usize; 3],
    /// Centre of the box's first voxel (m, map frame).
    pub origin: [f64; 3],
    pub voxel_size: f64,
    /// Signed distance per voxel (m); NaN where never observed.
    pub tsdf: Vec<f32>,
    /// Weight per voxel; 0 where never observed.
    pub weight: Vec<f32>,
}

impl TsdfVolume {
    /// The voxels from the one containing `min` to the one containing
    /// `max`, inclusive: the corners of every cube that
    /// [`TsdfVolume::mesh_region`] meshes for the same box. `None` for a
    /// non-finite or empty box or one of more than 2^28 voxels.
    pub fn dense_region(&self, min: [f64; 3], max: [f64; 3]) -> Option<DenseGrid> {
        if !min.iter().chain(&max).all(|v| v.is_finite()) {
            return None;
        }
        let (lo, hi) = (self.voxel_of(min), self.voxel_of(max));
        let mut dims = [0usize; 3];
        for a in 0..3 {
            if hi[a] < lo[a] {
                return None;
            }
            dims[a] = (hi[a] as i64 - lo[a] as i64 + 1) as usize;
        }
        let n = dims[0]
            .checked_mul(dims[1])
            .and_then(|v| v.checked_mul(dims[2]))
            .filter(|&n| n <= MAX_DENSE_VOXELS)?;
        let mut tsdf = vec![f32::NAN; n];
        let mut weight = vec![0.0f32; n];
        let mut i = 0;
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                let mut cached = ([i32::MIN; 3], None);
                for z in lo[2]..=hi[2] {
                    let v = [x, y, z];
                    let b = block_of(v);
                    if b != cached.0 {
                        cached = (b, self.store.get(b));
                    }
                    if let Some(blk) = cached.1 {
                        let vx = self.store.block(blk)[local_index(v)];
                        if vx.weight > 0.0 {
                            tsdf[i] = vx.tsdf;
                            weight[i] = vx.weight;
                        }
                    }
                    i += 1;
                }
            }
        }
        Some(DenseGrid {
            dims,
            origin: self.voxel_center(lo),
            voxel_size: self.voxel_size(),
            tsdf,
            weight,
        })
    }
}
