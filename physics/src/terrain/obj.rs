//! Wavefront OBJ reader: `v` vertices and `f` faces (indices with optional
//! `/texture/normal` parts, negative indices relative to the end); polygons
//! are split into fans; every other statement is skipped.

use super::mesh::{Material, Mesh, MeshError};

fn err(line: usize, why: impl Into<String>) -> MeshError {
    MeshError::Format(format!("OBJ line {line}: {}", why.into()))
}

pub fn parse(bytes: &[u8]) -> Result<Mesh, MeshError> {
    let text = std::str::from_utf8(bytes).map_err(|_| MeshError::Format("OBJ: not text".into()))?;
    let mut m = Mesh::default();
    let mut poly: Vec<u32> = Vec::with_capacity(16);
    for (n, line) in text.lines().enumerate() {
        let n = n + 1;
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let mut v = [0f32; 3];
                for x in v.iter_mut() {
                    let t = w.next().ok_or_else(|| err(n, "a vertex needs x y z"))?;
                    *x = t
                        .parse()
                        .map_err(|_| err(n, format!("\"{t}\" is not a number")))?;
                }
                m.vertices.push(v);
            }
            Some("f") => {
                poly.clear();
                for t in w {
                    let idx = t.split('/').next().unwrap_or("");
                    let i: i64 = idx
                        .parse()
                        .map_err(|_| err(n, format!("\"{t}\" is not a vertex index")))?;
                    let count = m.vertices.len() as i64;
                    let abs = if i < 0 { count + i } else { i - 1 };
                    if !(0..count).contains(&abs) {
                        return Err(err(n, format!("vertex {i} does not exist (have {count})")));
                    }
                    poly.push(abs as u32);
                }
                if poly.len() < 3 {
                    return Err(err(n, "a face needs 3 vertices"));
                }
                for k in 1..poly.len() - 1 {
                    m.triangles.push([poly[0], poly[k], poly[k + 1]]);
                    m.materials.push(Material::Rock);
                }
            }
            _ => {}
        }
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faces_with_slashes_and_negative_indices() {
        let m = parse(b"# cube corner\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4 -3 -2\n")
            .expect("parses");
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
        assert!(parse(b"v 0 0 0\nf 1 2 3\n").is_err());
        assert!(parse(b"v 0 0\n").is_err());
    }
}
