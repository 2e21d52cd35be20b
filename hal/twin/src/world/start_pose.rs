//! Where a rover starts in a world made from a mesh file: on floor with
//! room around it. The floor triangle nearest the floor's centroid can be
//! a boulder's top or a squeeze between walls, where a rover could not
//! turn or even leave; so the start is the floor point nearest the
//! centroid among those with the most room, up to `ROOM_M`.

use std::collections::HashMap;

use super::Mesh;

/// Room that counts as enough: nothing standing within this radius, m.
const ROOM_M: f64 = 1.2;
/// What stands: non-floor surface between these heights over the floor
/// point (a wall, a rock, a low roof) or under it (a drop), m.
const BAND_M: (f64, f64) = (0.05, 1.0);
const CELL_M: f64 = 0.5;

/// The start (x, y, floor z, yaw 0) among `floor` triangles (indices into
/// `mesh`), whose area-weighted centre is `centroid`; `None` without floor.
pub fn roomy_start(
    mesh: &Mesh,
    floor: &[usize],
    is_floor: &[bool],
    centroid: [f64; 3],
) -> Option<[f64; 4]> {
    // Points of what is not floor, hashed by cell.
    let mut standing: HashMap<(i64, i64), Vec<[f64; 3]>> = HashMap::new();
    let cell = |x: f64, y: f64| ((x / CELL_M).floor() as i64, (y / CELL_M).floor() as i64);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if is_floor[t] {
            continue;
        }
        let v = tri.map(|i| mesh.vertices[i as usize].map(f64::from));
        for p in [v[0], v[1], v[2], super::tri_centre(mesh, t)] {
            standing.entry(cell(p[0], p[1])).or_default().push(p);
        }
    }
    let reach = (ROOM_M / CELL_M).ceil() as i64;
    let room = |c: [f64; 3]| -> f64 {
        let (cx, cy) = cell(c[0], c[1]);
        let mut nearest = ROOM_M;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let Some(pts) = standing.get(&(cx + dx, cy + dy)) else {
                    continue;
                };
                for p in pts {
                    let dz = (p[2] - c[2]).abs();
                    if (BAND_M.0..=BAND_M.1).contains(&dz) {
                        nearest = nearest.min((p[0] - c[0]).hypot(p[1] - c[1]));
                    }
                }
            }
        }
        nearest
    };
    let dist2 = |c: [f64; 3]| (0..3).map(|k| (c[k] - centroid[k]).powi(2)).sum::<f64>();
    floor
        .iter()
        .map(|&t| {
            let c = super::tri_centre(mesh, t);
            (room(c), dist2(c), c)
        })
        // Most room first, then nearest the centroid.
        .min_by(|a, b| b.0.total_cmp(&a.0).then(a.1.total_cmp(&b.1)))
        .map(|(_, _, c)| [c[0], c[1], c[2], 0.0])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::shapes::add_box;
    use crate::world::Material;

    #[test]
    fn the_start_is_clear_of_a_rock_at_the_floors_centre() {
        // A 10 x 10 m floor of 0.5 m squares with a 0.6 m block at its
        // centre: the floor nearest the centroid is the block's top.
        let mut m = Mesh::default();
        for i in 0..20 {
            for j in 0..20 {
                let (x, y) = (-5.0 + 0.5 * i as f32, -5.0 + 0.5 * j as f32);
                let b = m.vertices.len() as u32;
                m.vertices.extend([
                    [x, y, 0.0],
                    [x + 0.5, y, 0.0],
                    [x + 0.5, y + 0.5, 0.0],
                    [x, y + 0.5, 0.0],
                ]);
                m.triangles.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
                m.materials.extend([Material::Rock; 2]);
            }
        }
        add_box(
            &mut m,
            [-0.3, -0.3, 0.0],
            [0.3, 0.3, 0.5],
            Material::Boulder,
        );
        let w = crate::world::World::from_mesh("test", m);
        let [x, y, z, _] = w.start;
        // A whole room's radius from the block's nearest vertex.
        assert!(x.hypot(y) >= 1.2, "start ({x}, {y}) next to the rock");
        assert!(
            z.abs() < 1e-6,
            "start on the floor, not the rock's top: {z}"
        );
    }
}
