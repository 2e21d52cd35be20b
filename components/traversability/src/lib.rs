//! The traversability map (section 2.2 of the reference paper): grown
//! from the rover's patch of the multi-level surface map through connected
//! patches (8-neighbourhood, height continuity, so levels stay apart),
//! each classified by a support plane fitted with RANSAC over the robot's
//! footprint (slope, steps) and an orientation-free body check against the
//! map.
//!
//! - [`params`]: the robot and the limits.
//! - [`plane`]: the deterministic RANSAC support plane.
//! - [`map`]: the graph, its growth, classes and queries.

pub mod blocked;
mod cell_heads;
pub mod map;
pub mod params;
pub mod plane;

pub use blocked::Blocked;
pub use map::{BuildError, BuildStats, Node, TravClass, TravMap, Window, NONE};
pub use params::TravParams;
