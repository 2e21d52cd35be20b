//! The 256-case marching-cubes table, generated at compile time (a `const`
//! evaluation) rather than written out.
//!
//! For each sign configuration, the surface is traced on the six faces of
//! the cube: on each face, walking its corners counter-clockwise as seen
//! from outside, every crossing from an outside corner (sdf >= 0) to an
//! inside one (sdf < 0) is joined to the next crossing along the walk. On a
//! face with two crossings that is the one contour; on an ambiguous face
//! (four crossings, inside corners diagonal) it cuts off each inside corner
//! on its own. The rule reads only the face's own four corners, so the two
//! cubes sharing a face draw the same segments (in opposite directions) and
//! meshes are closed wherever the volume is observed. The face segments
//! chain into loops (each crossed edge starts one segment and ends
//! another), and each loop is cut into a triangle fan. Every crossed edge
//! of the cube gets a vertex, exactly as in Lorensen and Cline's table, and
//! triangles wind counter-clockwise seen from outside the inside region:
//! their normals point from negative to positive distance.

/// Corner `c` of a cube sits at offset `(c & 1, (c >> 1) & 1, (c >> 2) & 1)`
/// from its first corner.
pub(crate) const fn corner_offset(c: usize) -> [usize; 3] {
    [c & 1, (c >> 1) & 1, (c >> 2) & 1]
}

/// The twelve edges as (first corner, axis): the second corner is the
/// first plus one along the axis. Four along x, four along y, four along z.
pub(crate) const EDGES: [(usize, usize); 12] = [
    (0, 0),
    (2, 0),
    (4, 0),
    (6, 0),
    (0, 1),
    (1, 1),
    (4, 1),
    (5, 1),
    (0, 2),
    (1, 2),
    (2, 2),
    (3, 2),
];

/// The six faces' corners, counter-clockwise seen from outside the cube
/// (checked in the tests): x = 0, x = 1, y = 0, y = 1, z = 0, z = 1.
pub(crate) const FACES: [[usize; 4]; 6] = [
    [0, 4, 6, 2],
    [1, 3, 7, 5],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 2, 3, 1],
    [4, 5, 7, 6],
];

/// The edge joining corners `a` and `b` (which differ in one bit).
const fn edge_between(a: usize, b: usize) -> usize {
    let first = if a < b { a } else { b };
    let axis = (a ^ b).trailing_zeros() as usize;
    let mut e = 0;
    while e < 12 {
        if EDGES[e].0 == first && EDGES[e].1 == axis {
            return e;
        }
        e += 1;
    }
    // Unreachable for face neighbours: fails the build if it were not.
    panic!("corners are not neighbours")
}

/// Triangles of one configuration (bit `c` set: corner `c` is inside),
/// as edge numbers, and their count. Twelve is more than enough: a fan
/// over all crossed edges gives at most 12 - 2 per loop.
const fn triangulate(config: usize) -> ([[u8; 3]; 12], usize) {
    // next[e]: the edge the surface goes to from edge e; 12 = none.
    let mut next = [12usize; 12];
    let mut f = 0;
    while f < 6 {
        let mut edges = [0usize; 4];
        let mut enters = [false; 4];
        let mut n = 0;
        let mut i = 0;
        while i < 4 {
            let a = FACES[f][i];
            let b = FACES[f][(i + 1) % 4];
            let (ia, ib) = ((config >> a) & 1 == 1, (config >> b) & 1 == 1);
            if ia != ib {
                edges[n] = edge_between(a, b);
                enters[n] = ib;
                n += 1;
            }
            i += 1;
        }
        let mut k = 0;
        while k < n {
            if enters[k] {
                next[edges[k]] = edges[(k + 1) % n];
            }
            k += 1;
        }
        f += 1;
    }
    let mut tris = [[0u8; 3]; 12];
    let mut count = 0;
    let mut seen = [false; 12];
    let mut e = 0;
    while e < 12 {
        if next[e] < 12 && !seen[e] {
            let mut ring = [0usize; 12];
            let mut n = 0;
            let mut cur = e;
            while !seen[cur] {
                seen[cur] = true;
                ring[n] = cur;
                n += 1;
                cur = next[cur];
            }
            let apex = fan_apex(&ring, n);
            let mut j = 1;
            while j + 1 < n {
                let a = ring[apex];
                let b = ring[(apex + j) % n];
                let c = ring[(apex + j + 1) % n];
                tris[count] = [a as u8, b as u8, c as u8];
                count += 1;
                j += 1;
            }
        }
        e += 1;
    }
    (tris, count)
}

/// Whether edges `a` and `b` lie on a common face of the cube.
const fn share_a_face(a: usize, b: usize) -> bool {
    let mut f = 0;
    while f < 6 {
        if on_face(a, f) && on_face(b, f) {
            return true;
        }
        f += 1;
    }
    false
}

const fn on_face(e: usize, f: usize) -> bool {
    let (c, axis) = EDGES[e];
    let d = c + (1 << axis);
    let (mut has_c, mut has_d) = (false, false);
    let mut i = 0;
    while i < 4 {
        has_c |= FACES[f][i] == c;
        has_d |= FACES[f][i] == d;
        i += 1;
    }
    has_c && has_d
}

/// The first loop position from which a fan draws no diagonal between two
/// edges of one face. Such a diagonal would lie in the face, where the
/// neighbouring cube may draw the same one: an edge of four triangles.
/// Every loop of the table has such a position (checked in the tests);
/// 0 otherwise.
const fn fan_apex(ring: &[usize; 12], n: usize) -> usize {
    let mut k = 0;
    while k < n {
        let mut ok = true;
        let mut j = 2;
        while j + 1 < n {
            if share_a_face(ring[k], ring[(k + j) % n]) {
                ok = false;
            }
            j += 1;
        }
        if ok {
            return k;
        }
        k += 1;
    }
    0
}

const fn max_triangles() -> usize {
    let mut m = 0;
    let mut c = 0;
    while c < 256 {
        let n = triangulate(c).1;
        if n > m {
            m = n;
        }
        c += 1;
    }
    m
}

/// Most triangles any configuration has.
pub(crate) const MAX_TRIANGLES: usize = max_triangles();

/// One configuration's triangles, as edge numbers.
#[derive(Clone, Copy)]
pub(crate) struct Case {
    pub count: u8,
    pub triangles: [[u8; 3]; MAX_TRIANGLES],
}

const fn build() -> [Case; 256] {
    let mut table = [Case {
        count: 0,
        triangles: [[0; 3]; MAX_TRIANGLES],
    }; 256];
    let mut c = 0;
    while c < 256 {
        let (tris, n) = triangulate(c);
        let mut i = 0;
        while i < n {
            table[c].triangles[i] = tris[i];
            i += 1;
        }
        table[c].count = n as u8;
        c += 1;
    }
    table
}

/// The table, indexed by configuration.
pub(crate) static CASES: [Case; 256] = build();

#[cfg(test)]
mod tests {
    use super::*;

    fn sub(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    fn cross(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }
    fn pos(c: usize) -> [i32; 3] {
        corner_offset(c).map(|v| v as i32)
    }

    #[test]
    fn faces_are_counter_clockwise_from_outside() {
        for (f, face) in FACES.iter().enumerate() {
            let axis = f / 2;
            let side = (f % 2) as i32;
            let mut outward = [0; 3];
            outward[axis] = 2 * side - 1;
            for i in 0..4 {
                let (a, b, c) = (pos(face[i]), pos(face[(i + 1) % 4]), pos(face[(i + 2) % 4]));
                assert_eq!(a[axis], side);
                let n = cross(sub(b, a), sub(c, b));
                assert_eq!(n, outward, "face {f}");
            }
        }
    }

    #[test]
    fn every_crossed_edge_gets_a_vertex_and_no_other() {
        // As in the classic table: at most five triangles a cube.
        const { assert!(MAX_TRIANGLES == 5) };
        for (config, case) in CASES.iter().enumerate() {
            let mut crossed = [false; 12];
            for (e, &(c, axis)) in EDGES.iter().enumerate() {
                let d = c + (1 << axis);
                crossed[e] = ((config >> c) & 1) != ((config >> d) & 1);
            }
            let mut used = [false; 12];
            for t in &case.triangles[..case.count as usize] {
                assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
                for &e in t {
                    used[e as usize] = true;
                }
            }
            assert_eq!(used, crossed, "config {config:08b}");
        }
        assert_eq!(CASES[0].count, 0);
        assert_eq!(CASES[255].count, 0);
        assert_eq!(CASES[1].count, 1);
    }

    /// Triangle sides joining two edges of one face are that face's
    /// contour segments: drawn once per face, so a neighbour sharing the
    /// face draws the same side the other way and no side has four
    /// triangles.
    #[test]
    fn only_contour_segments_lie_in_a_face() {
        for (config, case) in CASES.iter().enumerate() {
            let tris = &case.triangles[..case.count as usize];
            for f in 0..6 {
                let mut sides = Vec::new();
                for t in tris {
                    for k in 0..3 {
                        let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                        if on_face(a, f) && on_face(b, f) {
                            sides.push((a, b));
                        }
                    }
                }
                // One per crossed-edge pair on the face: 0, 1 or 2.
                let crossings = (0..12)
                    .filter(|&e| {
                        let (c, axis) = EDGES[e];
                        on_face(e, f) && ((config >> c) & 1) != ((config >> (c + (1 << axis))) & 1)
                    })
                    .count();
                assert_eq!(sides.len(), crossings / 2, "config {config:08b} face {f}");
            }
        }
    }

    /// With vertices at edge midpoints, a one-corner case's triangle faces
    /// away from its inside corner, and the complement faces the other way.
    #[test]
    fn triangles_face_from_inside_to_outside() {
        for c in 0..8 {
            for (config, sign) in [(1usize << c, 1), (255 ^ (1usize << c), -1)] {
                let case = &CASES[config];
                assert_eq!(case.count, 1);
                let mid = |e: u8| {
                    let (c0, axis) = EDGES[e as usize];
                    let mut p = pos(c0).map(|v| 2 * v);
                    p[axis] += 1;
                    p
                };
                let t = case.triangles[0];
                let (a, b, d) = (mid(t[0]), mid(t[1]), mid(t[2]));
                let n = cross(sub(b, a), sub(d, a));
                let away = sub(a, pos(c).map(|v| 2 * v));
                let dot: i32 = (0..3).map(|i| n[i] * away[i]).sum();
                assert!(dot * sign > 0, "corner {c} config {config:08b}");
            }
        }
    }
}
