//! Marching cubes (Lorensen and Cline 1987) over the TSDF volume.
//!
//! The lattice is the voxel centres; a cube joins eight neighbouring
//! centres, and takes part only if all eight voxels were observed (weight
//! above `TsdfParams::min_weight`). A vertex sits on every lattice edge
//! whose two ends differ in sign (inside: sdf < 0), linearly interpolated,
//! and is shared by every cube using that edge, within and across blocks:
//! the vertex count is what a marching cubes with vertex welding gives on
//! the same grid. Triangles wind so that their normals point from the
//! negative side (behind the surface) to the positive side (towards the
//! sensor). The case table is generated at compile time (`tables.rs`
//! explains how).

mod extract;
mod ply;
mod tables;

pub use extract::{MeshBuffers, MeshStats};
pub use ply::write_ply;

/// A triangle mesh: vertices in the map frame (m) and triangles as indices
/// into them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub vertices: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Empties the mesh, keeping its memory.
    pub fn clear(&mut self) {
        self.vertices.clear();
        self.triangles.clear();
    }
}
