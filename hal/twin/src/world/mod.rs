//! Worlds for the simulated rover: generated lava tubes and a multi-level
//! garage, flat ground, or any triangle mesh file. Every world is a triangle
//! mesh (the ground truth rays are cast against), the area of floor a rover
//! could reach (for coverage figures), and a start pose. The meshes, their
//! materials and their file formats are `speleo_physics::terrain`'s.

pub mod boulder_field;
pub mod garage;
pub mod lava_tube;
pub mod noise;
pub mod shapes;
mod start_pose;
pub mod waypoints;

use std::path::Path;

pub use speleo_physics::terrain::{CleanStats, Material, Mesh, MeshError};

/// Worlds known by name.
pub const NAMES: [&str; 5] = ["lava-tube", "short-tube", "garage", "boulders", "flat"];

#[derive(Clone, Debug)]
pub struct World {
    pub name: String,
    pub mesh: Mesh,
    pub floor_area_m2: f64,
    /// x, y, z (floor height), yaw of the rover's start.
    pub start: [f64; 4],
    /// A drivable route of floor points from the start (empty when the
    /// world does not know one): what scripted drives follow.
    pub route: Vec<[f64; 3]>,
    /// Poses the world names besides its start and route (x, y, floor z,
    /// yaw), for planning tests.
    pub named: Vec<(String, [f64; 4])>,
}

/// Steepest floor a rover counts as reachable in a mesh file.
const WALKABLE_DEG: f64 = 20.0;

impl World {
    /// A named world (`lava-tube`, `garage`, `boulders`, `flat`) or a mesh
    /// file (a path
    /// ending in .ply, .obj or .stl).
    pub fn build(name: &str, seed: u64) -> Result<World, MeshError> {
        match name {
            "lava-tube" => {
                let t = lava_tube::generate(seed, &lava_tube::LavaTubeParams::default());
                Ok(World {
                    name: name.into(),
                    mesh: t.mesh,
                    floor_area_m2: t.floor_area_m2,
                    start: t.start,
                    route: t.route,
                    named: Vec::new(),
                })
            }
            "short-tube" => {
                let t = lava_tube::generate(seed, &lava_tube::LavaTubeParams::short());
                Ok(World {
                    name: name.into(),
                    mesh: t.mesh,
                    floor_area_m2: t.floor_area_m2,
                    start: t.start,
                    route: t.route,
                    named: Vec::new(),
                })
            }
            "garage" => {
                let g = garage::generate();
                Ok(World {
                    name: name.into(),
                    mesh: g.mesh,
                    floor_area_m2: g.floor_area_m2,
                    start: g.start,
                    route: g.route,
                    named: Vec::new(),
                })
            }
            "boulders" => {
                let f = boulder_field::generate(seed);
                Ok(World {
                    name: name.into(),
                    mesh: f.mesh,
                    floor_area_m2: f.floor_area_m2,
                    start: boulder_field::START,
                    route: Vec::new(),
                    named: vec![("goal".into(), boulder_field::GOAL)],
                })
            }
            "flat" => {
                let mut m = Mesh::default();
                shapes::add_box(
                    &mut m,
                    [-100.0, -100.0, -0.5],
                    [100.0, 100.0, 0.0],
                    Material::Rock,
                );
                Ok(World {
                    name: name.into(),
                    mesh: m,
                    floor_area_m2: 200.0 * 200.0,
                    start: [0.0; 4],
                    route: Vec::new(),
                    named: Vec::new(),
                })
            }
            path if ["ply", "obj", "stl"]
                .contains(&speleo_hal::extension_of(Path::new(path)).as_str()) =>
            {
                let (mesh, _) = Mesh::load(Path::new(path))?;
                Ok(Self::from_mesh(path, mesh))
            }
            other => Err(MeshError::Format(format!(
                "unknown world \"{other}\" (worlds: {}, or a .ply/.obj/.stl file)",
                NAMES.join(", ")
            ))),
        }
    }

    /// A world from a mesh: the floor is every triangle facing up within
    /// 20 deg of level; the start is on floor with room around it, nearest
    /// the floor's centroid (`start_pose`).
    pub fn from_mesh(name: &str, mesh: Mesh) -> World {
        let cos_max = WALKABLE_DEG.to_radians().cos();
        let mut area = 0.0;
        let mut centroid = [0.0f64; 3];
        let mut floor_tris = Vec::new();
        for t in 0..mesh.triangles.len() {
            let (a, n) = mesh.triangle_geometry(t);
            if n[2] >= cos_max {
                let c = tri_centre(&mesh, t);
                for k in 0..3 {
                    centroid[k] += a * c[k];
                }
                area += a;
                floor_tris.push(t);
            }
        }
        if area > 0.0 {
            centroid = centroid.map(|c| c / area);
        }
        let mut is_floor = vec![false; mesh.triangles.len()];
        for &t in &floor_tris {
            is_floor[t] = true;
        }
        let start =
            start_pose::roomy_start(&mesh, &floor_tris, &is_floor, centroid).unwrap_or([0.0; 4]);
        World {
            name: name.into(),
            mesh,
            floor_area_m2: area,
            start,
            route: Vec::new(),
            named: Vec::new(),
        }
    }
}

fn tri_centre(m: &Mesh, t: usize) -> [f64; 3] {
    let [a, b, c] = m.triangles[t].map(|i| m.vertices[i as usize]);
    [0, 1, 2].map(|k| (a[k] as f64 + b[k] as f64 + c[k] as f64) / 3.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lava_tube_is_seeded_and_sized_like_the_papers() {
        let a = World::build("lava-tube", 1).expect("tube");
        let b = World::build("lava-tube", 1).expect("tube");
        let c = World::build("lava-tube", 2).expect("tube");
        assert_eq!(a.mesh, b.mesh);
        assert_ne!(a.mesh, c.mesh);
        let (lo, hi) = a.mesh.bounds();
        let extent = ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2)).sqrt();
        assert!(extent > 150.0 && extent < 300.0, "{extent}");
        // About 240 m of 3-6 m wide tube plus the branch.
        assert!(
            a.floor_area_m2 > 240.0 * 1.5 && a.floor_area_m2 < 270.0 * 5.0,
            "{}",
            a.floor_area_m2
        );
        assert!(a.mesh.materials.contains(&Material::Mud));
        assert!(a.mesh.materials.contains(&Material::Boulder));
        assert!(
            a.mesh.triangle_count() > 30_000,
            "{}",
            a.mesh.triangle_count()
        );
        // Every vertex is finite, every triangle real.
        let mut m = a.mesh.clone();
        let s = m.clean(1e-6);
        assert_eq!(s.degenerate_triangles, 0);
    }

    #[test]
    fn the_garage_has_three_levels_and_about_1300_m2() {
        let g = World::build("garage", 0).expect("garage");
        let (lo, hi) = g.mesh.bounds();
        assert!(hi[2] - lo[2] >= 3.0 * garage::LEVEL_HEIGHT - 0.5);
        assert!(
            (g.floor_area_m2 - 1300.0).abs() < 150.0,
            "{}",
            g.floor_area_m2
        );
    }

    #[test]
    fn mesh_files_become_worlds_and_errors_are_named() {
        let dir = std::env::temp_dir().join(format!("speleo-world-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let g = World::build("garage", 0).expect("garage");
        let path = dir.join("g.ply");
        let mut f = std::fs::File::create(&path).expect("create");
        g.mesh.write_ply(&mut f).expect("write");
        drop(f);
        let w = World::build(path.to_str().expect("utf8"), 0).expect("loads");
        assert!(w.mesh.triangle_count() > 0);
        assert!(w.floor_area_m2 > 1000.0);
        let e = World::build("moon", 0).expect_err("unknown");
        assert!(e.to_string().contains("lava-tube"), "{e}");
        let bad = dir.join("bad.stl");
        std::fs::write(&bad, b"not a mesh").expect("write");
        assert!(World::build(bad.to_str().expect("utf8"), 0).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
