//! Triangle meshes: the ground truth the simulation casts rays against and
//! drives on. Loaded from PLY (ASCII and binary), OBJ and STL, cleaned
//! (duplicate vertices welded, degenerate triangles dropped) and written as
//! binary PLY.

use std::collections::HashMap;
use std::path::Path;

use thiserror::Error;

/// What a triangle is made of (the physics picks friction by it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Material {
    #[default]
    Rock,
    Mud,
    Boulder,
    Concrete,
}

impl Material {
    pub fn code(self) -> u8 {
        self as u8
    }

    pub fn from_code(c: u8) -> Material {
        match c {
            1 => Material::Mud,
            2 => Material::Boulder,
            3 => Material::Concrete,
            _ => Material::Rock,
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub vertices: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
    /// One per triangle.
    pub materials: Vec<Material>,
}

#[derive(Debug, Error)]
pub enum MeshError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Format(String),
}

fn bad(why: impl Into<String>) -> MeshError {
    MeshError::Format(why.into())
}

/// What cleaning removed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CleanStats {
    pub welded_vertices: usize,
    pub degenerate_triangles: usize,
    pub unused_vertices: usize,
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f64; 3] {
    [
        a[0] as f64 - b[0] as f64,
        a[1] as f64 - b[1] as f64,
        a[2] as f64 - b[2] as f64,
    ]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Append another mesh.
    pub fn append(&mut self, other: &Mesh) {
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&other.vertices);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
        self.materials.extend_from_slice(&other.materials);
    }

    /// Add a triangle over new vertices.
    pub fn push_triangle(&mut self, a: [f32; 3], b: [f32; 3], c: [f32; 3], s: Material) {
        let i = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&[a, b, c]);
        self.triangles.push([i, i + 1, i + 2]);
        self.materials.push(s);
    }

    /// Area and unit normal of triangle `t` (normal zero if degenerate).
    pub fn triangle_geometry(&self, t: usize) -> (f64, [f64; 3]) {
        let [a, b, c] = self.triangles[t].map(|i| self.vertices[i as usize]);
        let n = cross(sub(b, a), sub(c, a));
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if len == 0.0 {
            return (0.0, [0.0; 3]);
        }
        (0.5 * len, [n[0] / len, n[1] / len, n[2] / len])
    }

    /// Axis-aligned bounds (min, max); zeros for an empty mesh.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for v in &self.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        if self.vertices.is_empty() {
            return ([0.0; 3], [0.0; 3]);
        }
        (lo, hi)
    }

    /// Weld vertices closer than `eps` (on a grid of that size), drop
    /// degenerate triangles (repeated vertex or zero area) and vertices no
    /// triangle uses. Deterministic: vertices keep their first-seen order.
    pub fn clean(&mut self, eps: f32) -> CleanStats {
        let mut stats = CleanStats::default();
        let key = |v: [f32; 3]| -> [i64; 3] {
            v.map(|x| (x as f64 / eps.max(1e-9) as f64).round() as i64)
        };
        let mut index_of: HashMap<[i64; 3], u32> = HashMap::with_capacity(self.vertices.len());
        let mut remap = Vec::with_capacity(self.vertices.len());
        let mut verts = Vec::with_capacity(self.vertices.len());
        for v in &self.vertices {
            let k = key(*v);
            let i = *index_of.entry(k).or_insert_with(|| {
                verts.push(*v);
                (verts.len() - 1) as u32
            });
            remap.push(i);
        }
        stats.welded_vertices = self.vertices.len() - verts.len();
        let mut tris = Vec::with_capacity(self.triangles.len());
        let mut surf = Vec::with_capacity(self.triangles.len());
        for (t, s) in self.triangles.iter().zip(self.materials.iter()) {
            let [a, b, c] = t.map(|i| remap[i as usize]);
            let degenerate = a == b || b == c || a == c || {
                let n = cross(
                    sub(verts[b as usize], verts[a as usize]),
                    sub(verts[c as usize], verts[a as usize]),
                );
                n[0] * n[0] + n[1] * n[1] + n[2] * n[2] == 0.0
            };
            if degenerate {
                stats.degenerate_triangles += 1;
            } else {
                tris.push([a, b, c]);
                surf.push(*s);
            }
        }
        // Drop vertices no triangle uses.
        let mut used = vec![u32::MAX; verts.len()];
        let mut compact = Vec::with_capacity(verts.len());
        for t in tris.iter_mut() {
            for i in t.iter_mut() {
                if used[*i as usize] == u32::MAX {
                    used[*i as usize] = compact.len() as u32;
                    compact.push(verts[*i as usize]);
                }
                *i = used[*i as usize];
            }
        }
        stats.unused_vertices = verts.len() - compact.len();
        self.vertices = compact;
        self.triangles = tris;
        self.materials = surf;
        stats
    }

    /// Load a PLY, OBJ or STL file (by extension), then clean it.
    pub fn load(path: &Path) -> Result<(Mesh, CleanStats), MeshError> {
        let bytes = std::fs::read(path).map_err(|source| MeshError::Read {
            path: path.display().to_string(),
            source,
        })?;
        let ext = extension_of(path);
        let mesh = match ext.as_str() {
            "ply" => super::ply::parse(&bytes),
            "obj" => super::obj::parse(&bytes),
            "stl" => super::stl::parse(&bytes),
            _ => Err(bad("mesh files end in .ply, .obj or .stl")),
        };
        let mut mesh = mesh.map_err(|e| match e {
            MeshError::Format(m) => MeshError::Format(format!("{}: {m}", path.display())),
            other => other,
        })?;
        if mesh.vertices.iter().flatten().any(|v| !v.is_finite()) {
            return Err(bad(format!(
                "{}: a vertex is not a finite number",
                path.display()
            )));
        }
        let stats = mesh.clean(1e-5);
        if mesh.triangles.is_empty() {
            return Err(bad(format!("{}: no usable triangle", path.display())));
        }
        Ok((mesh, stats))
    }

    /// Binary little-endian PLY with a per-face `surface` property.
    pub fn write_ply(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment speleo world\n\
             element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
             element face {}\nproperty list uchar int vertex_indices\nproperty uchar surface\n\
             end_header\n",
            self.vertices.len(),
            self.triangles.len()
        )?;
        let mut buf = Vec::with_capacity(self.vertices.len() * 12 + self.triangles.len() * 14);
        for v in &self.vertices {
            for x in v {
                buf.extend_from_slice(&x.to_le_bytes());
            }
        }
        for (t, s) in self.triangles.iter().zip(&self.materials) {
            buf.push(3);
            for i in t {
                buf.extend_from_slice(&(*i as i32).to_le_bytes());
            }
            buf.push(s.code());
        }
        w.write_all(&buf)
    }
}

/// A file's extension in lower case ("" when it has none): the format is
/// chosen by it.
fn extension_of(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// Bounded reservation: a header may claim more than the file holds.
pub(crate) fn reserve_for<T>(v: &mut Vec<T>, claimed: usize, bytes_left: usize, min_size: usize) {
    v.reserve(claimed.min(bytes_left / min_size.max(1) + 1));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cleaning_welds_and_drops() {
        let mut m = Mesh::default();
        m.push_triangle([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], Material::Rock);
        m.push_triangle(
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            Material::Mud,
        );
        // Degenerate: a line.
        m.push_triangle([0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], Material::Rock);
        let s = m.clean(1e-6);
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.triangles.len(), 2);
        assert_eq!(s.degenerate_triangles, 1);
        assert_eq!(s.welded_vertices, 9 - 5);
        assert_eq!(s.unused_vertices, 1);
        assert_eq!(m.materials, vec![Material::Rock, Material::Mud]);
        let (area, n) = m.triangle_geometry(0);
        assert!((area - 0.5).abs() < 1e-12);
        assert_eq!(n, [0.0, 0.0, 1.0]);
    }
}
