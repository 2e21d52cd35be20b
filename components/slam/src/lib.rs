//! Graph SLAM for the rover (section 2.1 of Speleo's reference paper).
//!
//! - [`registration`]: voxel downsampling, per-point covariances and
//!   Generalized-ICP between two clouds.
//! - [`lie`]: SO(3)/SE(3) maps and Jacobians shared by the factors.
//! - [`graph`] and [`solver`]: pose-graph factors and Levenberg-Marquardt on
//!   a sparse Cholesky factorisation whose symbolic analysis is reused.
//! - [`g2o`]: the g2o text format and the SE-Sync objective.

pub mod batch;
pub mod deskew;
pub mod factors;
pub mod g2o;
pub mod graph_slam;
pub mod initialize;
pub mod lie;
pub mod params;
pub mod registration;
pub mod solver;
pub mod staging;
