//! Truncated signed distance volume (Curless and Levoy 1996).
//!
//! Voxels of `voxel_size_m` (voxel `i` spans `[i, i + 1) * voxel_size_m`
//! on each axis, its centre at `(i + 0.5) * voxel_size_m`) in blocks of
//! 8x8x8, taken from a pool of `max_blocks` blocks at construction and
//! found through a deterministic open-addressing hash of the block
//! coordinates. Each point updates the voxels its ray crosses within the
//! truncation distance of it (the [`VoxelRay`] walk), vdbfusion-style: the
//! signed distance is the depth of the point minus the depth of the
//! voxel's centre along the ray, clamped to the truncation distance, and
//! averaged with the weights of the [`Weighting`].
//!
//! Speed: within a block, voxels are stored in Morton order (a cache line
//! holds a 2x2x2 brick); a small direct-mapped cache of recent blocks
//! answers most block lookups without hashing; and rays are processed as
//! a two-stage pipeline (the next ray's voxels are found and prefetched
//! while the previous ray's are updated, in order, so the results are
//! those of one ray after the other).

mod blocks;
pub mod dda;
mod dense;
mod volume;

pub use blocks::{Voxel, BLOCK_SIDE, BLOCK_VOXELS};
pub use dda::VoxelRay;
pub use dense::DenseGrid;
pub use volume::{
    IntegrateStats, TsdfParams, TsdfStats, TsdfVolume, Weighting, MAX_BLOCKS, MAX_TRUNCATION_VOXELS,
};

pub(crate) use blocks::local_index;
