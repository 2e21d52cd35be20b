//! Extraction: a pass over the allocated blocks, each with a 9x9x9 copy of
//! its voxels and its upper neighbours' boundary voxels, so that cubes
//! spanning block boundaries read plain arrays.

use super::tables::{corner_offset, CASES, EDGES};
use super::Mesh;
use crate::tsdf::{local_index, TsdfVolume, Voxel, BLOCK_SIDE, BLOCK_VOXELS};

/// No vertex yet on this edge.
const NONE: u32 = u32::MAX;
/// Lattice points along a side of a block's gathered neighbourhood.
const SIDE: usize = BLOCK_SIDE + 1;
const GATHERED: usize = SIDE * SIDE * SIDE;

/// The mesh and the scratch space of the extraction, kept by the caller:
/// once they have grown to the largest pass, meshing again allocates
/// nothing.
#[derive(Debug, Default)]
pub struct MeshBuffers {
    /// The result of the last extraction.
    pub mesh: Mesh,
    /// Per pool block: the pass that last made vertices on its edges and
    /// its slab of `edge_vertices` in that pass.
    slab_of: Vec<(u32, u32)>,
    /// Per slab (a block the pass made vertices in, in the order it came
    /// to them), per voxel: the vertex on the lattice edge from the
    /// voxel's centre towards +x, +y, +z. A region of a few blocks needs
    /// a few slabs, not one per block of the volume: meshing a 0.25 m tile
    /// of a large volume once took scratch for every block (62 MiB).
    edge_vertices: Vec<[u32; 3]>,
    /// Slabs handed out in this pass.
    slabs: usize,
    generation: u32,
}

impl MeshBuffers {
    pub fn new() -> MeshBuffers {
        MeshBuffers::default()
    }

    /// Buffers that mesh regions of a volume of up to `blocks` pool blocks
    /// with vertices in up to `slabs` blocks, and meshes of up to
    /// `triangles` triangles, without allocating.
    pub fn with_capacity(blocks: usize, slabs: usize, triangles: usize) -> MeshBuffers {
        let mut b = MeshBuffers::default();
        b.slab_of.resize(blocks, (0, 0));
        b.edge_vertices.reserve_exact(slabs * BLOCK_VOXELS);
        b.mesh.triangles.reserve_exact(triangles);
        // Marching cubes meshes have about half as many vertices as
        // triangles; shared edges make it fewer.
        b.mesh.vertices.reserve_exact(triangles);
        b
    }

    /// Readies the scratch space for `blocks` pool blocks and a new pass.
    fn begin(&mut self, blocks: usize) {
        self.mesh.clear();
        if self.slab_of.len() < blocks {
            self.slab_of.resize(blocks, (0, 0));
        }
        self.slabs = 0;
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.slab_of.fill((0, 0));
            self.generation = 1;
        }
    }

    /// The first edge-vertex entry of pool block `blk` in this pass, its
    /// slab cleared and handed out on the first call.
    fn slab(&mut self, blk: usize) -> usize {
        let (pass, slab) = self.slab_of[blk];
        if pass == self.generation {
            return slab as usize * BLOCK_VOXELS;
        }
        let slab = self.slabs;
        self.slabs += 1;
        let range = slab * BLOCK_VOXELS..(slab + 1) * BLOCK_VOXELS;
        if self.edge_vertices.len() < range.end {
            self.edge_vertices.resize(range.end, [NONE; 3]);
        }
        self.edge_vertices[range.clone()].fill([NONE; 3]);
        self.slab_of[blk] = (self.generation, slab as u32);
        range.start
    }

    /// Bytes held by the buffers.
    pub fn memory_bytes(&self) -> usize {
        self.mesh.vertices.capacity() * 12
            + self.mesh.triangles.capacity() * 12
            + self.edge_vertices.capacity() * 12
            + self.slab_of.capacity() * 8
    }
}

/// What an extraction produced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MeshStats {
    /// Cubes that produced triangles.
    pub cubes: u64,
    /// Cubes crossing the surface that were skipped because a corner was
    /// unobserved.
    pub unobserved_cubes: u64,
    pub vertices: usize,
    pub triangles: usize,
    /// The mesh reached `u32::MAX` vertices and is incomplete.
    pub truncated: bool,
}

impl TsdfVolume {
    /// Meshes every allocated block into `buffers.mesh`.
    pub fn mesh_all(&self, buffers: &mut MeshBuffers) -> MeshStats {
        let all = ([i32::MIN; 3], [i32::MAX; 3]);
        self.mesh_cubes(all, buffers)
    }

    /// Meshes the cubes whose first corner (lowest voxel centre) is in a
    /// voxel from the one containing `min` up to, not including, the one
    /// containing `max`: boxes sharing a face tile without overlap, and
    /// [`TsdfVolume::dense_region`] with the same box holds every corner.
    /// A non-finite box meshes nothing.
    pub fn mesh_region(
        &self,
        min: [f64; 3],
        max: [f64; 3],
        buffers: &mut MeshBuffers,
    ) -> MeshStats {
        if !min.iter().chain(&max).all(|v| v.is_finite()) {
            buffers.begin(0);
            return MeshStats::default();
        }
        self.mesh_cubes((self.voxel_of(min), self.voxel_of(max)), buffers)
    }

    /// Meshes the cubes with first corner in `lo..hi` (voxels, per axis).
    fn mesh_cubes(&self, (lo, hi): ([i32; 3], [i32; 3]), buf: &mut MeshBuffers) -> MeshStats {
        let store = &self.store;
        buf.begin(store.used());
        let mut st = MeshStats::default();
        let min_weight = self.params().min_weight;
        let mut gathered = Gathered {
            vals: [f32::NAN; GATHERED],
            inside: [0; SIDE * SIDE],
            outside: [0; SIDE * SIDE],
        };
        for (n, &b) in store.coords().iter().enumerate() {
            // The block's cube range, clipped to the region (local coords).
            let base = b.map(|c| c * BLOCK_SIDE as i32);
            let mut from = [0usize; 3];
            let mut to = [0usize; 3];
            let mut empty = false;
            for a in 0..3 {
                let f = (lo[a].max(base[a]) as i64 - base[a] as i64).max(0);
                let t = (hi[a] as i64 - base[a] as i64).min(BLOCK_SIDE as i64);
                empty |= t <= f;
                from[a] = f as usize;
                to[a] = t.max(0) as usize;
            }
            if empty {
                continue;
            }
            // Pool entries of this block and its +x, +y, +z neighbours
            // (index dx + 2 dy + 4 dz).
            let neighbours: [Option<u32>; 8] = std::array::from_fn(|i| {
                if i == 0 {
                    Some(n as u32)
                } else {
                    let o = corner_offset(i);
                    store.get([b[0] + o[0] as i32, b[1] + o[1] as i32, b[2] + o[2] as i32])
                }
            });
            if !gather(self, &neighbours, min_weight, &mut gathered) {
                continue;
            }
            let mut ctx = BlockPass {
                vol: self,
                base,
                neighbours,
                g: &gathered,
                buf,
                stats: &mut st,
            };
            ctx.cubes(from, to);
        }
        st.vertices = buf.mesh.vertices.len();
        st.triangles = buf.mesh.triangles.len();
        st
    }
}

/// A block's neighbourhood: the 9x9x9 lattice points from its first voxel
/// (its own voxels and its upper neighbours' first layers), NaN where
/// unobserved, and per row along x (index `y + 9 z`) the bits of the
/// points inside (sdf < 0) and outside (sdf >= 0).
struct Gathered {
    vals: [f32; GATHERED],
    inside: [u16; SIDE * SIDE],
    outside: [u16; SIDE * SIDE],
}

/// Where each voxel of a block (in storage order) goes in the gathered
/// array.
const OWN: [u16; BLOCK_VOXELS] = {
    let mut t = [0u16; BLOCK_VOXELS];
    let mut x = 0;
    while x < BLOCK_SIDE {
        let mut y = 0;
        while y < BLOCK_SIDE {
            let mut z = 0;
            while z < BLOCK_SIDE {
                t[local_index_const(x, y, z)] = (x + SIDE * (y + SIDE * z)) as u16;
                z += 1;
            }
            y += 1;
        }
        x += 1;
    }
    t
};

/// Lattice points of the gathered array taken from the upper neighbours
/// (x, y or z = 8): 9^3 - 8^3.
const BORDER: usize = GATHERED - BLOCK_VOXELS;

/// For each border point: its gathered index, which neighbour holds it
/// (dx + 2 dy + 4 dz) and its index there.
const BORDER_POINTS: [(u16, u8, u16); BORDER] = {
    let mut t = [(0u16, 0u8, 0u16); BORDER];
    let mut n = 0;
    let mut z = 0;
    while z < SIDE {
        let mut y = 0;
        while y < SIDE {
            let mut x = 0;
            while x < SIDE {
                if x == BLOCK_SIDE || y == BLOCK_SIDE || z == BLOCK_SIDE {
                    let which = (x >> 3) | ((y >> 3) << 1) | ((z >> 3) << 2);
                    t[n] = (
                        (x + SIDE * (y + SIDE * z)) as u16,
                        which as u8,
                        local_index_const(x & 7, y & 7, z & 7) as u16,
                    );
                    n += 1;
                }
                x += 1;
            }
            y += 1;
        }
        z += 1;
    }
    t
};

/// [`local_index`] for tables built at compile time.
const fn local_index_const(x: usize, y: usize, z: usize) -> usize {
    let mut i = 0;
    let mut bit = 0;
    while bit < 3 {
        i |= ((x >> bit) & 1) << (3 * bit);
        i |= ((y >> bit) & 1) << (3 * bit + 1);
        i |= ((z >> bit) & 1) << (3 * bit + 2);
        bit += 1;
    }
    i
}

/// Fills `g` from the pool entries `nb` (this block and its upper
/// neighbours, index dx + 2 dy + 4 dz); false if no cube there can cross
/// the surface (no observed inside point or no observed outside point).
/// The block is read in storage order (sequential memory).
fn gather(vol: &TsdfVolume, nb: &[Option<u32>; 8], min_weight: f32, g: &mut Gathered) -> bool {
    let value = |vx: &Voxel| {
        if vx.weight > min_weight {
            vx.tsdf
        } else {
            f32::NAN
        }
    };
    if let Some(own) = nb[0] {
        for (vx, &at) in vol.store.block(own).iter().zip(OWN.iter()) {
            g.vals[at as usize] = value(vx);
        }
    }
    for &(at, which, local) in BORDER_POINTS.iter() {
        g.vals[at as usize] = match nb[which as usize] {
            Some(b) => value(&vol.store.block(b)[local as usize]),
            None => f32::NAN,
        };
    }
    let (mut any_in, mut any_out) = (0u16, 0u16);
    for (r, row) in g.vals.chunks_exact(SIDE).enumerate() {
        let (mut row_in, mut row_out) = (0u16, 0u16);
        for (x, &v) in row.iter().enumerate() {
            row_in |= ((v < 0.0) as u16) << x;
            row_out |= ((v >= 0.0) as u16) << x;
        }
        g.inside[r] = row_in;
        g.outside[r] = row_out;
        any_in |= row_in;
        any_out |= row_out;
    }
    any_in != 0 && any_out != 0
}

/// Offset in the gathered array of corner `c` from a cube's first corner.
const fn corner_step(c: usize) -> usize {
    let o = corner_offset(c);
    o[0] + SIDE * o[1] + SIDE * SIDE * o[2]
}
const CORNER_STEPS: [usize; 8] = {
    let mut s = [0; 8];
    let mut c = 0;
    while c < 8 {
        s[c] = corner_step(c);
        c += 1;
    }
    s
};

struct BlockPass<'a> {
    vol: &'a TsdfVolume,
    /// Voxel coordinates of the block's first voxel.
    base: [i32; 3],
    neighbours: [Option<u32>; 8],
    g: &'a Gathered,
    buf: &'a mut MeshBuffers,
    stats: &'a mut MeshStats,
}

impl BlockPass<'_> {
    /// Meshes the cubes with first corner in `from..to` (local), visiting
    /// only those with an inside and an outside corner, found a row of
    /// eight at a time from the gathered bits.
    fn cubes(&mut self, from: [usize; 3], to: [usize; 3]) {
        let xs: u16 = ((1u32 << to[0]) - (1u32 << from[0])) as u16;
        for z in from[2]..to[2] {
            for y in from[1]..to[1] {
                let rows = [
                    y + SIDE * z,
                    y + 1 + SIDE * z,
                    y + SIDE * (z + 1),
                    y + 1 + SIDE * (z + 1),
                ];
                let (mut i, mut o) = (0u16, 0u16);
                for r in rows {
                    i |= self.g.inside[r];
                    o |= self.g.outside[r];
                }
                // Bit x: a corner of cube x (points x and x + 1) is in/out.
                let mut todo = (i | (i >> 1)) & (o | (o >> 1)) & xs;
                while todo != 0 {
                    let x = todo.trailing_zeros() as usize;
                    todo &= todo - 1;
                    self.cube([x, y, z]);
                }
            }
        }
    }

    #[inline(always)]
    fn cube(&mut self, l: [usize; 3]) {
        let first = l[0] + SIDE * l[1] + SIDE * SIDE * l[2];
        let mut v = [0.0f32; 8];
        // Corners inside (sdf < 0) and outside (sdf >= 0); an unobserved
        // corner (NaN) is neither.
        let (mut inside, mut outside) = (0usize, 0usize);
        for c in 0..8 {
            v[c] = self.g.vals[first + CORNER_STEPS[c]];
            inside |= ((v[c] < 0.0) as usize) << c;
            outside |= ((v[c] >= 0.0) as usize) << c;
        }
        if inside == 0 || outside == 0 {
            return;
        }
        if inside | outside != 255 {
            self.stats.unobserved_cubes += 1;
            return;
        }
        let config = inside;
        let case = &CASES[config];
        let mut ids = [NONE; 12];
        for t in &case.triangles[..case.count as usize] {
            let mut tri = [0u32; 3];
            for (k, &e) in t.iter().enumerate() {
                let e = e as usize;
                if ids[e] == NONE {
                    ids[e] = self.vertex(l, e, &v);
                }
                tri[k] = ids[e];
            }
            if tri.contains(&NONE) {
                self.stats.truncated = true;
                return;
            }
            self.buf.mesh.triangles.push(tri);
        }
        self.stats.cubes += 1;
    }

    /// The vertex on edge `e` of the cube with first corner `l` (local),
    /// made if this pass has not made it yet.
    fn vertex(&mut self, l: [usize; 3], e: usize, v: &[f32; 8]) -> u32 {
        let (c0, axis) = EDGES[e];
        let o = corner_offset(c0);
        let owner = [l[0] + o[0], l[1] + o[1], l[2] + o[2]];
        let which = (owner[0] >> 3) | ((owner[1] >> 3) << 1) | ((owner[2] >> 3) << 2);
        // The corner was observed, so its block exists.
        let Some(blk) = self.neighbours[which] else {
            return NONE;
        };
        let buf = &mut *self.buf;
        let first = buf.slab(blk as usize);
        let local = local_index(owner.map(|c| c as i32));
        let slot = &mut buf.edge_vertices[first + local][axis];
        if *slot != NONE {
            return *slot;
        }
        if buf.mesh.vertices.len() >= NONE as usize {
            return NONE;
        }
        let (va, vb) = (v[c0], v[c0 + (1 << axis)]);
        // Signs differ, so va != vb.
        let t = va as f64 / (va as f64 - vb as f64);
        let g = [
            self.base[0] + owner[0] as i32,
            self.base[1] + owner[1] as i32,
            self.base[2] + owner[2] as i32,
        ];
        let mut p = self.vol.voxel_center(g);
        p[axis] += t * self.vol.voxel_size();
        let id = buf.mesh.vertices.len() as u32;
        buf.mesh.vertices.push(p.map(|c| c as f32));
        *slot = id;
        id
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tsdf::TsdfParams;
    use std::collections::HashMap;

    fn volume() -> TsdfVolume {
        volume_of(64)
    }

    /// A volume of 0.1 m voxels with room for `max_blocks` blocks.
    fn volume_of(max_blocks: usize) -> TsdfVolume {
        TsdfVolume::new(TsdfParams {
            voxel_size_m: 0.1,
            max_blocks,
            ..TsdfParams::default()
        })
        .expect("valid params")
    }

    /// A random field of signs (ambiguous faces everywhere) inside an
    /// observed, positive shell, spanning several blocks with negative
    /// coordinates: the mesh must be closed, consistently oriented, and
    /// enclose a positive volume (normals point out of the negative side).
    #[test]
    fn random_fields_give_closed_oriented_meshes() {
        let mut state = 11u64;
        for _ in 0..20 {
            let mut vol = volume();
            let (lo, hi) = (-6, 7);
            for x in lo..=hi {
                for y in lo..=hi {
                    for z in lo..=hi {
                        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
                        let r = crate::hash::mix64(state);
                        let inner = [x, y, z].iter().all(|&c| c > lo && c < hi);
                        let tsdf = if inner {
                            (r >> 40) as f32 / (1u64 << 24) as f32 - 0.6
                        } else {
                            0.5
                        };
                        assert!(vol.set_voxel([x, y, z], Voxel { tsdf, weight: 1.0 }));
                    }
                }
            }
            let mut buf = MeshBuffers::new();
            let st = vol.mesh_all(&mut buf);
            let mesh = &buf.mesh;
            assert!(st.triangles > 100 && st.unobserved_cubes == 0);
            let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
            for t in &mesh.triangles {
                for k in 0..3 {
                    *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
                }
            }
            for (&(a, b), &n) in &directed {
                assert_eq!(n, 1, "edge {a}-{b} used twice in one direction");
                assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}-{b} open");
            }
            let mut volume6 = 0.0f64;
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|i| mesh.vertices[i as usize].map(|v| v as f64));
                volume6 += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]);
            }
            assert!(volume6 > 0.0, "{volume6}");
        }
    }

    #[test]
    fn the_gather_tables_match_local_index() {
        for x in 0..8 {
            for y in 0..8 {
                for z in 0..8 {
                    let l = local_index([x as i32, y as i32, z as i32]);
                    assert_eq!(local_index_const(x, y, z), l);
                    assert_eq!(OWN[l] as usize, x + SIDE * (y + SIDE * z));
                }
            }
        }
        let mut seen = [false; GATHERED];
        for &a in OWN.iter() {
            seen[a as usize] = true;
        }
        for &(a, _, _) in BORDER_POINTS.iter() {
            assert!(!seen[a as usize]);
            seen[a as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
    }

    /// A ball of radius 0.2 m (0.1 m voxels) round the origin, in blocks
    /// either side of it.
    fn ball() -> TsdfVolume {
        let mut vol = volume();
        for x in -3..3 {
            for y in -3..3 {
                for z in -3..3 {
                    let tsdf = (x * x + y * y + z * z) as f32 * 0.01 - 0.04;
                    vol.set_voxel([x, y, z], Voxel { tsdf, weight: 1.0 });
                }
            }
        }
        vol
    }

    #[test]
    fn repeated_meshing_reuses_the_buffers_and_gives_the_same_mesh() {
        let vol = ball();
        let mut buf = MeshBuffers::new();
        let a = vol.mesh_all(&mut buf);
        let first = buf.mesh.clone();
        let b = vol.mesh_all(&mut buf);
        assert_eq!(a, b);
        assert_eq!(first, buf.mesh);
        // One block's worth of cubes, in a region, is a part of it.
        let r = vol.mesh_region([0.0; 3], [0.8; 3], &mut buf);
        assert!(r.triangles > 0 && r.triangles < a.triangles);
        let none = vol.mesh_region([f64::NAN; 3], [1.0; 3], &mut buf);
        assert_eq!(none.triangles, 0);
        assert!(buf.mesh.triangles.is_empty());
    }

    #[test]
    fn a_small_region_of_a_large_volume_takes_scratch_for_its_blocks_only() {
        // A floor at z = 0.05 m over 8 x 8 blocks (0.8 m each at 0.1 m).
        let mut vol = volume_of(256);
        for x in -32..32 {
            for y in -32..32 {
                for z in -1..2 {
                    let tsdf = (z as f32 + 0.5) * 0.1 - 0.05;
                    vol.set_voxel([x, y, z], Voxel { tsdf, weight: 1.0 });
                }
            }
        }
        let mut buf = MeshBuffers::new();
        let all = vol.mesh_all(&mut buf);
        assert!(all.triangles > 4000, "{}", all.triangles);
        let mut small = MeshBuffers::new();
        // A quarter-metre tile: cubes of one block, vertices on its edges
        // and its upper neighbours'.
        let r = vol.mesh_region([0.0, 0.0, -0.5], [0.25, 0.25, 0.5], &mut small);
        assert!(r.triangles > 0);
        assert!(
            small.edge_vertices.len() <= 4 * BLOCK_VOXELS,
            "{} slabs for one block's cubes",
            small.edge_vertices.len() / BLOCK_VOXELS
        );
        // The same triangles as the whole volume's mesh has there, and
        // meshing the whole volume after the tile is unchanged.
        let again = vol.mesh_all(&mut small);
        assert_eq!(again, all);
        assert_eq!(small.mesh, buf.mesh);
    }

    #[test]
    fn buffers_made_with_capacity_mesh_a_region_without_growing() {
        let vol = ball();
        let mut buf = MeshBuffers::with_capacity(64, 8, 1024);
        let before = buf.memory_bytes();
        let r = vol.mesh_region([-0.3; 3], [0.3; 3], &mut buf);
        assert!(r.triangles > 0);
        assert_eq!(buf.memory_bytes(), before);
    }
}
