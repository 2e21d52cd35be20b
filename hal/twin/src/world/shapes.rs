//! Closed primitives for building worlds.

use speleo_physics::terrain::{Material, Mesh};

/// An axis-aligned box, outward normals.
pub fn add_box(m: &mut Mesh, lo: [f32; 3], hi: [f32; 3], s: Material) {
    let c = |x: usize, y: usize, z: usize| -> [f32; 3] {
        [
            if x == 0 { lo[0] } else { hi[0] },
            if y == 0 { lo[1] } else { hi[1] },
            if z == 0 { lo[2] } else { hi[2] },
        ]
    };
    add_hexahedron(
        m,
        [
            c(0, 0, 0),
            c(1, 0, 0),
            c(1, 1, 0),
            c(0, 1, 0),
            c(0, 0, 1),
            c(1, 0, 1),
            c(1, 1, 1),
            c(0, 1, 1),
        ],
        s,
    );
}

/// A hexahedron from its bottom face (counter-clockwise seen from above)
/// and top face in the same order; outward normals.
pub fn add_hexahedron(m: &mut Mesh, v: [[f32; 3]; 8], s: Material) {
    let base = m.vertices.len() as u32;
    m.vertices.extend_from_slice(&v);
    let quads = [
        [0, 3, 2, 1], // bottom (facing down)
        [4, 5, 6, 7], // top
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];
    for q in quads {
        m.triangles.push([base + q[0], base + q[1], base + q[2]]);
        m.triangles.push([base + q[0], base + q[2], base + q[3]]);
        m.materials.push(s);
        m.materials.push(s);
    }
}

/// A rock: an octahedron subdivided once and jittered, `size` across,
/// resting on `floor_z` at (x, y).
pub fn add_rock(m: &mut Mesh, x: f64, y: f64, floor_z: f64, size: f64, seed: u64) {
    let r = 0.5 * size;
    // Octahedron vertices, then edge midpoints pushed out to the sphere.
    let dirs: [[f64; 3]; 6] = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let faces = [
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    // Flattened a little and sunk into the floor so it sits, not floats.
    let cz = floor_z + 0.35 * r;
    // Jitter keyed by direction, so a vertex shared by two faces moves once
    // (no cracks for rays to slip through).
    let point = |d: [f64; 3]| -> [f32; 3] {
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let key = |v: f64| (v * 8.0).round() as i64;
        let j = super::noise::lattice(seed, key(d[0]) * 64 + key(d[1]), key(d[2]));
        let s = r * (1.0 + 0.25 * j);
        [
            (x + s * d[0] / n) as f32,
            (y + s * d[1] / n) as f32,
            (cz + 0.7 * s * d[2] / n) as f32,
        ]
    };
    for f in faces.iter() {
        let [a, b, c] = f.map(|i| dirs[i]);
        let mid = |p: [f64; 3], q: [f64; 3]| {
            [
                (p[0] + q[0]) / 2.0,
                (p[1] + q[1]) / 2.0,
                (p[2] + q[2]) / 2.0,
            ]
        };
        let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
        let (pa, pb, pc) = (point(a), point(b), point(c));
        let (pab, pbc, pca) = (point(ab), point(bc), point(ca));
        for t in [
            [pa, pab, pca],
            [pab, pb, pbc],
            [pca, pbc, pc],
            [pab, pbc, pca],
        ] {
            m.push_triangle(t[0], t[1], t[2], Material::Boulder);
        }
    }
}
