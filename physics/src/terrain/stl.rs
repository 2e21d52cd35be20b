//! STL reader, binary and ASCII. Every facet brings its own three vertices;
//! cleaning welds them.

use super::mesh::{reserve_for, Material, Mesh, MeshError};

fn err(why: impl Into<String>) -> MeshError {
    MeshError::Format(format!("STL: {}", why.into()))
}

pub fn parse(bytes: &[u8]) -> Result<Mesh, MeshError> {
    // Binary when the facet count in the header matches the size exactly
    // (ASCII files also start with "solid", and some binary ones do too).
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        if n.checked_mul(50).and_then(|b| b.checked_add(84)) == Some(bytes.len()) {
            return Ok(binary(bytes, n));
        }
    }
    let text = std::str::from_utf8(bytes)
        .map_err(|_| err("neither binary (the facet count does not match the size) nor ASCII"))?;
    if !text.trim_start().starts_with("solid") {
        return Err(err(
            "neither binary (the facet count does not match the size) nor ASCII",
        ));
    }
    ascii(text)
}

fn binary(bytes: &[u8], n: usize) -> Mesh {
    let mut m = Mesh::default();
    reserve_for(&mut m.vertices, n * 3, bytes.len(), 16);
    for f in bytes[84..].chunks_exact(50).take(n) {
        let v = |k: usize| -> [f32; 3] {
            let o = 12 + 12 * k;
            let r =
                |i: usize| f32::from_le_bytes([f[o + i], f[o + i + 1], f[o + i + 2], f[o + i + 3]]);
            [r(0), r(4), r(8)]
        };
        m.push_triangle(v(0), v(1), v(2), Material::Rock);
    }
    m
}

fn ascii(text: &str) -> Result<Mesh, MeshError> {
    let mut m = Mesh::default();
    let mut corner: Vec<[f32; 3]> = Vec::with_capacity(3);
    for (n, line) in text.lines().enumerate() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("vertex") => {
                let mut v = [0f32; 3];
                for x in v.iter_mut() {
                    let t = w
                        .next()
                        .ok_or_else(|| err(format!("line {}: a vertex needs x y z", n + 1)))?;
                    *x = t
                        .parse()
                        .map_err(|_| err(format!("line {}: \"{t}\" is not a number", n + 1)))?;
                }
                corner.push(v);
            }
            Some("endloop") => {
                if corner.len() != 3 {
                    return Err(err(format!(
                        "line {}: a facet has {} vertices",
                        n + 1,
                        corner.len()
                    )));
                }
                m.push_triangle(corner[0], corner[1], corner[2], Material::Rock);
                corner.clear();
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
    fn ascii_and_binary() {
        let a = b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        let m = parse(a).expect("ascii");
        assert_eq!(m.triangles.len(), 1);
        let mut b = vec![0u8; 84 + 50];
        b[80] = 1;
        for (k, v) in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
            .iter()
            .enumerate()
        {
            for (i, x) in v.iter().enumerate() {
                let o = 84 + 12 + 12 * k + 4 * i;
                b[o..o + 4].copy_from_slice(&x.to_le_bytes());
            }
        }
        let m2 = parse(&b).expect("binary");
        assert_eq!(m2.vertices, m.vertices);
        assert!(parse(&b[..100]).is_err());
        assert!(parse(b"solid\nouter loop\nvertex 0 0 0\nendloop\n").is_err());
    }
}
