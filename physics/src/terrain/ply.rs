//! PLY reader: ASCII and binary (little- and big-endian), any properties;
//! `x, y, z` of `vertex` and `vertex_indices` (or `vertex_index`) of `face`
//! are kept, polygons are split into triangle fans, everything else is
//! skipped by its declared type.

use super::mesh::{reserve_for, Material, Mesh, MeshError};

#[derive(Clone, Copy, Debug, PartialEq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        Some(match s {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }
}

#[derive(Debug)]
enum Prop {
    Scalar(String, Ty),
    List(String, Ty, Ty),
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Le,
    Be,
}

fn err(why: impl Into<String>) -> MeshError {
    MeshError::Format(format!("PLY: {}", why.into()))
}

/// Values of one row, read from ASCII tokens or binary bytes.
struct Reader<'a> {
    fmt: Format,
    bytes: &'a [u8],
    at: usize,
    tokens: std::str::SplitAsciiWhitespace<'a>,
}

impl Reader<'_> {
    fn read(&mut self, ty: Ty) -> Result<f64, MeshError> {
        if self.fmt == Format::Ascii {
            let t = self.tokens.next().ok_or_else(|| err("file ends early"))?;
            return t
                .parse::<f64>()
                .map_err(|_| err(format!("\"{t}\" is not a number")));
        }
        let n = ty.size();
        let b = self
            .bytes
            .get(self.at..self.at + n)
            .ok_or_else(|| err("file ends early"))?;
        self.at += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.fmt == Format::Be {
            a[..n].reverse();
        }
        Ok(match ty {
            Ty::I8 => a[0] as i8 as f64,
            Ty::U8 => a[0] as f64,
            Ty::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
            Ty::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
            Ty::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::F64 => f64::from_le_bytes(a),
        })
    }

    fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.at)
    }
}

pub fn parse(bytes: &[u8]) -> Result<Mesh, MeshError> {
    let end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .ok_or_else(|| err("no end_header"))?;
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| err("header is not text"))?;
    let mut lines = header.lines();
    if lines.next().map(str::trim) != Some("ply") {
        return Err(err("does not start with \"ply\""));
    }
    let mut fmt = None;
    let mut elements: Vec<Element> = Vec::new();
    for line in lines {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["format", f, _] => {
                fmt = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Le,
                    "binary_big_endian" => Format::Be,
                    other => return Err(err(format!("unknown format {other}"))),
                })
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| err(format!("element {name}: bad count {count}")))?,
                props: Vec::new(),
            }),
            ["property", "list", ct, it, name] => {
                let e = elements
                    .last_mut()
                    .ok_or_else(|| err("property before element"))?;
                let c = Ty::parse(ct).ok_or_else(|| err(format!("unknown type {ct}")))?;
                let i = Ty::parse(it).ok_or_else(|| err(format!("unknown type {it}")))?;
                e.props.push(Prop::List(name.to_string(), c, i));
            }
            ["property", ty, name] => {
                let e = elements
                    .last_mut()
                    .ok_or_else(|| err("property before element"))?;
                let t = Ty::parse(ty).ok_or_else(|| err(format!("unknown type {ty}")))?;
                e.props.push(Prop::Scalar(name.to_string(), t));
            }
            [] | ["comment", ..] | ["obj_info", ..] => {}
            _ => return Err(err(format!("unreadable header line \"{line}\""))),
        }
    }
    let fmt = fmt.ok_or_else(|| err("no format line"))?;
    // The body starts after "end_header" and its line end.
    let mut body = end + 10;
    while body < bytes.len() && (bytes[body] == b'\r' || bytes[body] == b'\n') {
        body += 1;
        if bytes[body - 1] == b'\n' {
            break;
        }
    }
    let body_bytes = &bytes[body.min(bytes.len())..];
    let text = if fmt == Format::Ascii {
        std::str::from_utf8(body_bytes).map_err(|_| err("ASCII body is not text"))?
    } else {
        ""
    };
    let mut r = Reader {
        fmt,
        bytes: body_bytes,
        at: 0,
        tokens: text.split_ascii_whitespace(),
    };
    let mut mesh = Mesh::default();
    let mut vertex_count = 0usize;
    for e in &elements {
        let is_vertex = e.name == "vertex";
        let is_face = e.name == "face";
        if is_vertex {
            let has = |axis: &str| {
                e.props
                    .iter()
                    .any(|p| matches!(p, Prop::Scalar(n, _) if n == axis))
            };
            if e.count > 0 && !(has("x") && has("y") && has("z")) {
                return Err(err("the vertex element lacks an x, y or z property"));
            }
            vertex_count = e.count;
            reserve_for(
                &mut mesh.vertices,
                e.count,
                r.remaining().max(text.len()),
                3,
            );
        }
        for _ in 0..e.count {
            let mut xyz = [0f32; 3];
            let mut surface = Material::Rock;
            for p in &e.props {
                match p {
                    Prop::Scalar(name, ty) => {
                        let v = r.read(*ty)?;
                        match (is_vertex, is_face, name.as_str()) {
                            (true, _, "x") => xyz[0] = v as f32,
                            (true, _, "y") => xyz[1] = v as f32,
                            (true, _, "z") => xyz[2] = v as f32,
                            (_, true, "surface") => surface = Material::from_code(v as u8),
                            _ => {}
                        }
                    }
                    Prop::List(name, ct, it) => {
                        let n = r.read(*ct)?;
                        if !(0.0..=1024.0).contains(&n) || n.fract() != 0.0 {
                            return Err(err(format!("list of {n} items")));
                        }
                        let n = n as usize;
                        let keep = is_face && (name == "vertex_indices" || name == "vertex_index");
                        let mut poly = [0u32; 1024];
                        for slot in poly.iter_mut().take(n) {
                            let v = r.read(*it)?;
                            if keep {
                                if v < 0.0 || v >= vertex_count as f64 || v.fract() != 0.0 {
                                    return Err(err(format!(
                                        "face index {v} outside 0..{vertex_count}"
                                    )));
                                }
                                *slot = v as u32;
                            }
                        }
                        if keep {
                            for k in 1..n.saturating_sub(1) {
                                mesh.triangles.push([poly[0], poly[k], poly[k + 1]]);
                            }
                        }
                    }
                }
            }
            if is_vertex {
                mesh.vertices.push(xyz);
            }
            if is_face {
                // Material applies to every triangle of this face.
                let added = mesh.triangles.len() - mesh.materials.len();
                mesh.materials.extend(std::iter::repeat_n(surface, added));
            }
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_with_quads_and_extra_properties() {
        let text = "ply\nformat ascii 1.0\ncomment x\nelement vertex 4\nproperty float x\n\
                    property float y\nproperty float z\nproperty uchar red\n\
                    element face 1\nproperty list uchar int vertex_indices\nend_header\n\
                    0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n4 0 1 2 3\n";
        let m = parse(text.as_bytes()).expect("parses");
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn vertices_without_coordinates_are_refused() {
        let text = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1\n2\n";
        let e = parse(text).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("x, y or z"), "{e}");
    }

    #[test]
    fn binary_round_trip_through_the_writer() {
        let mut m = Mesh::default();
        m.push_triangle([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5], Material::Mud);
        let mut out = Vec::new();
        m.write_ply(&mut out).expect("writes");
        let back = parse(&out).expect("parses");
        assert_eq!(back, m);
    }

    #[test]
    fn broken_files_are_refused() {
        assert!(parse(
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1 2"
        )
        .is_err());
        assert!(parse(b"plx\nend_header\n").is_err());
        let bad_index =
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                         property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                         end_header\n0 0 0\n3 0 1 7\n";
        let e = parse(bad_index.as_bytes()).expect_err("index");
        assert!(e.to_string().contains("outside"), "{e}");
        // A header claiming a billion vertices in a tiny file.
        let huge = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nend_header\n\x00\x00";
        assert!(parse(huge).is_err());
    }
}
