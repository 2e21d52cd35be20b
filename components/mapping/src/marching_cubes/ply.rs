//! Binary little-endian PLY output of a mesh.

use std::io::{self, Write};

use super::Mesh;

/// Writes `mesh` as binary little-endian PLY: vertices as `float x y z`,
/// faces as `list uchar int vertex_indices`. Fails (nothing panics) on a
/// write error or a triangle whose index is not a vertex or exceeds `int`.
/// Writes in 4 KiB pieces; no need for a `BufWriter`.
pub fn write_ply(mesh: &Mesh, mut out: impl Write) -> io::Result<()> {
    let n = mesh.vertices.len();
    if let Some(t) = mesh
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= n || i > i32::MAX as u32))
    {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("triangle {t:?} indexes past the {n} vertices"),
        ));
    }
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment speleo-mapping marching cubes\n\
         element vertex {n}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.triangles.len()
    )?;
    let mut chunk = Chunk::default();
    for v in &mesh.vertices {
        for c in v {
            chunk.put(&mut out, &c.to_le_bytes())?;
        }
    }
    for t in &mesh.triangles {
        chunk.put(&mut out, &[3])?;
        for &i in t {
            chunk.put(&mut out, &(i as i32).to_le_bytes())?;
        }
    }
    chunk.flush(&mut out)?;
    out.flush()
}

/// A small staging buffer: one `write_all` per 4 KiB, not per number.
struct Chunk {
    bytes: [u8; 4096],
    len: usize,
}

impl Default for Chunk {
    fn default() -> Self {
        Chunk {
            bytes: [0; 4096],
            len: 0,
        }
    }
}

impl Chunk {
    fn put(&mut self, out: &mut impl Write, b: &[u8]) -> io::Result<()> {
        if self.len + b.len() > self.bytes.len() {
            self.flush(out)?;
        }
        self.bytes[self.len..self.len + b.len()].copy_from_slice(b);
        self.len += b.len();
        Ok(())
    }

    fn flush(&mut self, out: &mut impl Write) -> io::Result<()> {
        out.write_all(&self.bytes[..self.len])?;
        self.len = 0;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_and_body_have_the_declared_layout() {
        let mesh = Mesh {
            vertices: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5]],
            triangles: vec![[0, 1, 2]],
        };
        let mut out = Vec::new();
        write_ply(&mesh, &mut out).expect("written");
        let end = b"end_header\n";
        let at = out
            .windows(end.len())
            .position(|w| w == end)
            .expect("header end")
            + end.len();
        let header = std::str::from_utf8(&out[..at]).expect("ascii");
        assert!(header.contains("element vertex 3\n"));
        assert!(header.contains("element face 1\n"));
        let body = &out[at..];
        assert_eq!(body.len(), 3 * 12 + 13);
        assert_eq!(&body[32..36], &0.5f32.to_le_bytes());
        assert_eq!(body[36], 3);
        assert_eq!(&body[45..49], &2i32.to_le_bytes());
    }

    #[test]
    fn a_bad_index_is_an_error() {
        let mesh = Mesh {
            vertices: vec![[0.0; 3]],
            triangles: vec![[0, 0, 1]],
        };
        assert!(write_ply(&mesh, Vec::new()).is_err());
    }
}
