//! Scan registration: Generalized-ICP between two LiDAR clouds.
//!
//! A cloud goes through [`voxel`] downsampling, a [`kdtree`] and per-point
//! [`covariance`]s into a [`PreparedCloud`]; [`align`] then finds the
//! transform target <- source and the Hessian the pose graph uses as the
//! scan factor's information. Every buffer is sized at construction; a
//! prepared cloud is rebuilt and an alignment run without allocating, on
//! one thread, with bit-identical results for identical inputs.

pub mod covariance;
pub mod degeneracy;
pub mod gicp;
pub mod kdtree;
pub mod voxel;

pub use gicp::{
    align, cost, perturb, Aligner, Alignment, GicpParams, Kernel, PrepareStats, PreparedCloud,
};
pub use kdtree::{KdTree, Neighbor};
pub use voxel::{VoxelGrid, VoxelStats};
