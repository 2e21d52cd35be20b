//! The simulated world's ground: the keyframe clouds around the plan in a
//! TSDF, meshed a tile at a time.

use speleo_hal::world::{Mesh, Surface};
use speleo_mapping::marching_cubes::MeshBuffers;
use speleo_mapping::tsdf::{TsdfParams, TsdfVolume, Weighting};

use crate::SimulatorParams;

/// Blocks a tile's vertices can lie in: a tile spans two blocks (0.4 m
/// at 5 cm voxels) and their upper neighbours each way, the box's height
/// in blocks (up to 6 m at 5 cm voxels).
const TILE_SLABS: usize = 3 * 3 * 16;
/// Triangles reserved for a tile's mesh (a wall tile has ~600).
const TILE_TRIANGLES: usize = 8192;

pub(crate) struct Terrain {
    tsdf: TsdfVolume,
    buffers: MeshBuffers,
    /// The last tile's triangles, for rapier.
    pub chunk: Mesh,
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    tile_m: f64,
    /// Square tiles over the box: `nx` along x, `tiles` in all.
    nx: usize,
    pub tiles: usize,
    pub triangles: usize,
}

impl Terrain {
    pub fn new(p: &SimulatorParams) -> Result<Self, String> {
        let tsdf = TsdfVolume::new(TsdfParams {
            voxel_size_m: p.voxel_m,
            truncation_voxels: 3.0,
            max_blocks: p.max_blocks,
            weighting: Weighting::Constant,
            min_weight: 0.0,
        })
        .map_err(|e| e.to_string())?;
        Ok(Terrain {
            tsdf,
            buffers: MeshBuffers::with_capacity(p.max_blocks, TILE_SLABS, TILE_TRIANGLES),
            chunk: Mesh {
                vertices: Vec::with_capacity(TILE_TRIANGLES),
                triangles: Vec::with_capacity(TILE_TRIANGLES),
                surfaces: Vec::with_capacity(TILE_TRIANGLES),
            },
            lo: [0.0; 3],
            hi: [0.0; 3],
            tile_m: p.tile_m,
            nx: 1,
            tiles: 0,
            triangles: 0,
        })
    }

    /// A new, empty world over the box `lo..hi`.
    pub fn begin(&mut self, lo: [f64; 3], hi: [f64; 3]) {
        self.tsdf.clear();
        self.lo = lo;
        self.hi = hi;
        let n = |k: usize| ((hi[k] - lo[k]) / self.tile_m).ceil().max(1.0) as usize;
        self.nx = n(0);
        self.tiles = self.nx * n(1);
        self.triangles = 0;
    }

    /// Whether `p` lies in the box grown by `grow` in x and y.
    pub fn near(&self, p: [f64; 3], grow: f64) -> bool {
        (0..2).all(|k| p[k] >= self.lo[k] - grow && p[k] <= self.hi[k] + grow)
    }

    /// Integrate the points of `points` inside the box (with a voxel's
    /// margin) seen from `origin`; the number integrated.
    pub fn integrate(&mut self, origin: [f64; 3], points: &mut Vec<[f64; 3]>) -> u64 {
        let (lo, hi) = self.integrated_box();
        points.retain(|p| (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k]));
        self.tsdf.integrate(origin, points).integrated
    }

    /// The box (with a voxel's margin) whose points are integrated.
    pub fn integrated_box(&self) -> ([f64; 3], [f64; 3]) {
        self.grown(self.lo, self.hi)
    }

    /// The box `lo..hi` with the integration's margin.
    pub fn grown(&self, lo: [f64; 3], hi: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let m = 2.0 * self.tsdf.voxel_size();
        (lo.map(|v| v - m), hi.map(|v| v + m))
    }

    /// The highest seen ground in the column at `x`, `y` between `top`
    /// and `bottom`: where the signed distance, walking down, turns from
    /// free space to behind a surface (interpolated between the voxel
    /// centres). `None` where the column holds no such crossing: a hole in
    /// the scans, or inside a rock.
    pub fn surface_z(&self, x: f64, y: f64, top: f64, bottom: f64) -> Option<f64> {
        let [vx, vy, mut vz] = self.tsdf.voxel_of([x, y, top]);
        let end = self.tsdf.voxel_of([x, y, bottom])[2];
        let mut above: Option<(f64, f32)> = None;
        while vz >= end {
            let v = [vx, vy, vz];
            let seen = self.tsdf.voxel(v).filter(|s| s.weight > 0.0);
            match (above, seen) {
                (Some((za, a)), Some(b)) if a > 0.0 && b.tsdf <= 0.0 => {
                    let zb = self.tsdf.voxel_center(v)[2];
                    let f = f64::from(a / (a - b.tsdf));
                    return Some(za + (zb - za) * f);
                }
                _ => {}
            }
            above = seen.map(|s| (self.tsdf.voxel_center(v)[2], s.tsdf));
            vz -= 1;
        }
        None
    }

    /// Tile `i`'s corners in x and y.
    pub fn tile_bounds(&self, i: usize) -> ([f64; 2], [f64; 2]) {
        let (ix, iy) = ((i % self.nx) as f64, (i / self.nx) as f64);
        let lo = [self.lo[0] + ix * self.tile_m, self.lo[1] + iy * self.tile_m];
        let hi = [
            (lo[0] + self.tile_m).min(self.hi[0]),
            (lo[1] + self.tile_m).min(self.hi[1]),
        ];
        (lo, hi)
    }

    /// Mesh tile `i` into `chunk` (rock: the simulator knows no better).
    pub fn mesh_tile(&mut self, i: usize) {
        let (a, b) = self.tile_bounds(i);
        let lo = [a[0], a[1], self.lo[2]];
        let hi = [b[0], b[1], self.hi[2]];
        self.tsdf.mesh_region(lo, hi, &mut self.buffers);
        let m = &self.buffers.mesh;
        self.chunk.vertices.clear();
        self.chunk.triangles.clear();
        self.chunk.surfaces.clear();
        self.chunk.vertices.extend_from_slice(&m.vertices);
        self.chunk.triangles.extend_from_slice(&m.triangles);
        self.chunk
            .surfaces
            .extend(std::iter::repeat_n(Surface::Rock, m.triangles.len()));
        self.triangles += m.triangles.len();
    }

    pub fn memory_bytes(&self) -> usize {
        self.tsdf.stats().memory_bytes + self.buffers.memory_bytes()
    }
}
