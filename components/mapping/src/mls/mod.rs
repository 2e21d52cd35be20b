//! Multi-level surface map (Triebel, Pfaff, Burgard 2006).
//!
//! A 2D grid of `resolution_m` cells, unbounded in extent, held in a hash
//! table of `max_cells` cells fixed at construction. Each cell keeps up to
//! `max_patches_per_cell` surface patches sorted by height: points within
//! `gap_m` of a patch's height interval update it (a Kalman update of the
//! mean, plus min, max and count), others start a new level (a floor under
//! a ceiling, a ledge over a passage). A patch whose points span more than
//! `vertical_threshold_m` becomes vertical (a wall). Two patches that come
//! within the gap of each other fuse.

mod index;
mod map;
mod patch;
mod unseen;

pub use map::{
    CellSlot, InsertStats, MlsMap, MlsParams, MlsStats, MAX_CELLS, MAX_PATCHES_PER_CELL,
};
pub use patch::{drop_at, ground_near, Patch, PatchKind, SLAB_GAP_M, TOP_BAND_M};
pub use unseen::ExpectedGround;
