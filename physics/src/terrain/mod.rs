//! Terrain: triangle meshes with what each triangle is made of, the ground
//! the rover drives on and the LiDAR's rays strike. Loaded from PLY (ASCII
//! and binary), OBJ and STL, cleaned and written as binary PLY.

mod mesh;
pub mod obj;
pub mod ply;
pub mod stl;

pub use mesh::{CleanStats, Material, Mesh, MeshError};
