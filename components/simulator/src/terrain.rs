//! The simulated world's ground: the keyframe clouds around the plan in a
//! TSDF, meshed a tile at a time.

use speleo_mapping::marching_cubes::MeshBuffers;
use speleo_mapping::tsdf::{TsdfParams, TsdfVolume, Weighting};
use speleo_physics::{Material, Mesh};

use crate::grip::ReturnsBySlot;
use crate::SimulatorParams;

/// Blocks a tile's vertices can lie in: a tile spans two blocks (0.4 m
/// at 5 cm voxels) and their upper neighbours each way, the box's height
/// in blocks (up to 6 m at 5 cm voxels).
const TILE_SLABS: usize = 3 * 3 * 16;
/// Triangles reserved for a tile's mesh (a wall tile has ~600).
const TILE_TRIANGLES: usize = 8192;
/// The see-through grid's cells, m, and its side at most (51.2 m): a
/// box larger than that keeps no marks past it.
const THROUGH_CELL_M: f64 = 0.1;
const THROUGH_SIDE: usize = 512;
/// A column is seen through at a height this far under it and not
/// further (see [`Terrain::seen_through`]), m.
const THROUGH_UNDER_M: (f64, f64) = (0.1, 0.5);
/// Rays count when they end this far under the plane, m: a ray that
/// crosses it over a slope going down ends just past it.
const THROUGH_DEEP_M: f64 = 0.15;
/// Rays count from sensors this far over the plane, m: on the plan's
/// level (the mast is 0.52 m high). From a level below, rays pass under
/// the slab the plan drives on and mark its columns.
const THROUGH_ORIGIN_M: f64 = 0.5;
/// Rays that make a column seen through: one stray ray is noise.
const THROUGH_RAYS: u8 = 2;

/// The points a world reads of the clouds (`InternalSim::read_region`):
/// inside the box, or under the see-through plane with their rays down
/// through it inside the box's x and y. The others change nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReadRegion {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    pub through_z: f64,
}

impl ReadRegion {
    /// Whether point `p`, seen from `origin`, is read.
    pub fn reads(&self, origin: Option<[f64; 3]>, p: &[f64; 3]) -> bool {
        let (lo, hi) = (self.lo, self.hi);
        if (0..3).all(|a| p[a] >= lo[a] && p[a] <= hi[a]) {
            return true;
        }
        let z = self.through_z;
        match origin {
            Some(o) if o[2] > z && p[2] < z => {
                let c = crossing(o, p, z);
                (0..2).all(|a| c[a] >= lo[a] && c[a] <= hi[a])
            }
            _ => false,
        }
    }
}

/// Where the ray from `o` to `p` crosses the height `z` (x, y).
fn crossing(o: [f64; 3], p: &[f64; 3], z: f64) -> [f64; 2] {
    let t = (o[2] - z) / (o[2] - p[2]);
    [o[0] + t * (p[0] - o[0]), o[1] + t * (p[1] - o[1])]
}

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
    /// Rays that went down through the plane at `through_z`, per column
    /// of the box (`through_nx` a row, saturating): the evidence of a
    /// drop, where the TSDF keeps none (it carves only a few voxels in
    /// front of each point, and points under the box are left out).
    through: Vec<u8>,
    through_nx: usize,
    through_ny: usize,
    through_z: f64,
    /// The brightest return integrated into each TSDF voxel, by its slot.
    returns: ReturnsBySlot,
    /// Ground whose reflectance reads under this is meshed as mud
    /// (see [`SimulatorParams::low_grip_reflectance`]).
    low_grip_reflectance: f64,
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
        let slots = if p.low_grip_reflectance > 0.0 {
            tsdf.slots()
        } else {
            0
        };
        Ok(Terrain {
            returns: ReturnsBySlot::new(slots),
            low_grip_reflectance: p.low_grip_reflectance,
            tsdf,
            buffers: MeshBuffers::with_capacity(p.max_blocks, TILE_SLABS, TILE_TRIANGLES),
            chunk: Mesh {
                vertices: Vec::with_capacity(TILE_TRIANGLES),
                triangles: Vec::with_capacity(TILE_TRIANGLES),
                materials: Vec::with_capacity(TILE_TRIANGLES),
            },
            lo: [0.0; 3],
            hi: [0.0; 3],
            tile_m: p.tile_m,
            nx: 1,
            tiles: 0,
            triangles: 0,
            through: vec![0; THROUGH_SIDE * THROUGH_SIDE],
            through_nx: 0,
            through_ny: 0,
            through_z: f64::NEG_INFINITY,
        })
    }

    /// A new, empty world over the box `lo..hi`; rays down through
    /// `through_z` are counted (see [`seen_through`](Self::seen_through)).
    pub fn begin(&mut self, lo: [f64; 3], hi: [f64; 3], through_z: f64) {
        self.returns.clear(self.tsdf.slots_used());
        self.tsdf.clear();
        self.lo = lo;
        self.hi = hi;
        let n = |k: usize| ((hi[k] - lo[k]) / self.tile_m).ceil().max(1.0) as usize;
        self.nx = n(0);
        self.tiles = self.nx * n(1);
        self.triangles = 0;
        let cells = |k: usize| {
            let c = ((hi[k] - lo[k]) / THROUGH_CELL_M).ceil();
            if c.is_finite() && c > 0.0 {
                (c as usize).min(THROUGH_SIDE)
            } else {
                0
            }
        };
        self.through_nx = cells(0);
        self.through_ny = cells(1);
        self.through[..self.through_nx * self.through_ny].fill(0);
        self.through_z = through_z;
    }

    /// The see-through grid's index of the column at `x`, `y`.
    fn through_cell(&self, x: f64, y: f64) -> Option<usize> {
        let i = ((x - self.lo[0]) / THROUGH_CELL_M).floor();
        let j = ((y - self.lo[1]) / THROUGH_CELL_M).floor();
        (i >= 0.0 && j >= 0.0 && i < self.through_nx as f64 && j < self.through_ny as f64)
            .then(|| j as usize * self.through_nx + i as usize)
    }

    /// Count the rays from `origin` that go down through the plane at
    /// `through_z` where they cross it.
    fn count_through(&mut self, origin: [f64; 3], points: &[[f64; 3]]) {
        let z = self.through_z;
        // False for a NaN origin too.
        let on_plan_level = origin[2] > z + THROUGH_ORIGIN_M;
        if !on_plan_level {
            return;
        }
        for p in points {
            if p[2] < z - THROUGH_DEEP_M {
                let [x, y] = crossing(origin, p, z);
                if let Some(c) = self.through_cell(x, y) {
                    self.through[c] = self.through[c].saturating_add(1);
                }
            }
        }
    }

    /// The plane rays are counted down through (see
    /// [`seen_through`](Self::seen_through)).
    pub fn through_z(&self) -> f64 {
        self.through_z
    }

    /// Whether rays went down through the column at `x`, `y` under ground
    /// believed at `z`, by 0.1 to 0.5 m: no ground stands there at `z`
    /// (rays from above would have ended on it). The plane is the plan's
    /// lowest ground less a little, so this speaks of columns near the
    /// plan's lowest level only; over a slope's top it is silent.
    pub fn seen_through(&self, x: f64, y: f64, z: f64) -> bool {
        let under = z - self.through_z;
        under >= THROUGH_UNDER_M.0
            && under <= THROUGH_UNDER_M.1
            && self
                .through_cell(x, y)
                .is_some_and(|c| self.through[c] >= THROUGH_RAYS)
    }

    /// Whether `p` lies in the box grown by `grow` in x and y.
    pub fn near(&self, p: [f64; 3], grow: f64) -> bool {
        (0..2).all(|k| p[k] >= self.lo[k] - grow && p[k] <= self.hi[k] + grow)
    }

    /// Integrate the points of `points` inside the box (with a voxel's
    /// margin) seen from `origin`, with their returns' `intensities` when
    /// these are as many; the number integrated.
    pub fn integrate(
        &mut self,
        origin: [f64; 3],
        points: &mut Vec<[f64; 3]>,
        intensities: &mut [u8],
    ) -> u64 {
        self.count_through(origin, points);
        let (lo, hi) = self.integrated_box();
        let with_intensity = intensities.len() == points.len() && !self.returns.is_empty();
        let mut kept = 0;
        for i in 0..points.len() {
            let p = points[i];
            if (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k]) {
                points[kept] = p;
                if with_intensity {
                    intensities[kept] = intensities[i];
                }
                kept += 1;
            }
        }
        points.truncate(kept);
        let integrated = self.tsdf.integrate(origin, points).integrated;
        if with_intensity {
            for (p, &i) in points.iter().zip(intensities.iter()) {
                if let Some(s) = self.tsdf.voxel_slot(self.tsdf.voxel_of(*p)) {
                    self.returns.record(s, origin, *p, i);
                }
            }
        }
        integrated
    }

    /// Give each triangle of `mesh` (laid on the seen ground: the pad and
    /// the strip) the grip its ground reads.
    pub fn read_grip(&self, mesh: &mut Mesh) {
        if self.returns.is_empty() {
            return;
        }
        for (t, material) in mesh.triangles.iter().zip(mesh.materials.iter_mut()) {
            *material = self.grip_at(t.map(|v| mesh.vertices[v as usize]));
        }
    }

    /// Mud where the triangle's ground reads darker than
    /// `low_grip_reflectance`, rock elsewhere (and where nothing was read).
    fn grip_at(&self, corners: [[f32; 3]; 3]) -> Material {
        let c = corners.map(|v| v.map(f64::from));
        let centre = [0, 1, 2].map(|k| (c[0][k] + c[1][k] + c[2][k]) / 3.0);
        let (a, b) = (
            [0, 1, 2].map(|k| c[1][k] - c[0][k]),
            [0, 1, 2].map(|k| c[2][k] - c[0][k]),
        );
        let n = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if len <= 0.0 || !len.is_finite() {
            return Material::Rock;
        }
        if self.reads_low_grip(centre, n.map(|v| v / len), 0) {
            Material::Mud
        } else {
            Material::Rock
        }
    }

    /// Whether the ground at `p` reads darker than `low_grip_reflectance`:
    /// the brightest reflectance of the 3 x 3 x 3 voxels around the one
    /// holding `p` and of `below` more voxels straight down, the incidence
    /// taken against `normal`. A mesh triangle's normal follows the
    /// voxels' steps, not the surface a ray hit (rock read through single
    /// voxels reads as dark as 28); of a block of voxels at least one was
    /// hit near its normal, and mud lies in patches wider than the block.
    /// Nothing read there reads as rock.
    pub fn reads_low_grip(&self, p: [f64; 3], normal: [f64; 3], below: i32) -> bool {
        if self.returns.is_empty() {
            return false;
        }
        let v = self.tsdf.voxel_of(p);
        let block = (0..27).map(|i| [i % 3 - 1, i / 3 % 3 - 1, i / 9 - 1]);
        let column = (2..=below + 1).map(|d| [0, 0, -d]);
        let brightest = block
            .chain(column)
            .filter_map(|d| {
                self.tsdf
                    .voxel_slot([v[0] + d[0], v[1] + d[1], v[2] + d[2]])
            })
            .filter_map(|s| self.returns.reflectance(s, normal))
            .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r))));
        brightest.is_some_and(|r| r < self.low_grip_reflectance)
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
        self.column_ground(x, y, top, bottom, false)
    }

    /// As [`surface_z`](Self::surface_z), but `None` where an underside
    /// (behind a surface walking down, then free space) lies over the
    /// ground found: that ground lies under a slab, not under a hole in
    /// the slab's top. A ramp's top the rings missed, over a floor they
    /// saw under it, was laid on that floor: the strip sank into a pit a
    /// metre deep in the middle of the garage's first ramp, and plans up
    /// it tipped the simulated rover over while the real one drove them.
    pub fn open_ground_z(&self, x: f64, y: f64, top: f64, bottom: f64) -> Option<f64> {
        self.column_ground(x, y, top, bottom, true)
    }

    fn column_ground(
        &self,
        x: f64,
        y: f64,
        top: f64,
        bottom: f64,
        stop_at_underside: bool,
    ) -> Option<f64> {
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
                (Some((_, a)), Some(b)) if stop_at_underside && a <= 0.0 && b.tsdf > 0.0 => {
                    return None;
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

    /// Mesh tile `i` into `chunk`: rock, or mud where the ground's
    /// reflectance reads under [`SimulatorParams::low_grip_reflectance`].
    pub fn mesh_tile(&mut self, i: usize) {
        let (a, b) = self.tile_bounds(i);
        let lo = [a[0], a[1], self.lo[2]];
        let hi = [b[0], b[1], self.hi[2]];
        self.tsdf.mesh_region(lo, hi, &mut self.buffers);
        let m = &self.buffers.mesh;
        self.chunk.vertices.clear();
        self.chunk.triangles.clear();
        self.chunk.materials.clear();
        self.chunk.vertices.extend_from_slice(&m.vertices);
        self.chunk.triangles.extend_from_slice(&m.triangles);
        self.chunk
            .materials
            .extend(std::iter::repeat_n(Material::Rock, m.triangles.len()));
        if !self.returns.is_empty() {
            for i in 0..self.chunk.triangles.len() {
                let t = self.chunk.triangles[i];
                let grip = self.grip_at(t.map(|v| self.chunk.vertices[v as usize]));
                self.chunk.materials[i] = grip;
            }
        }
        self.triangles += m.triangles.len();
    }

    pub fn memory_bytes(&self) -> usize {
        self.tsdf.stats().memory_bytes + self.buffers.memory_bytes() + self.returns.memory_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_case_keeps_the_rays_down_through_the_plane_within_the_box() {
        let r = ReadRegion {
            lo: [0.0, 0.0, -1.0],
            hi: [4.0, 4.0, 2.0],
            through_z: -0.15,
        };
        let o = Some([1.0, 1.0, 0.5]);
        assert!(r.reads(o, &[2.0, 2.0, 0.0]), "inside the box");
        // Down through the plane at x = 1.65, inside; ends under the box.
        assert!(r.reads(o, &[3.0, 1.0, -1.5]));
        // Through it at x = 7.5, outside.
        assert!(!r.reads(o, &[11.0, 1.0, -1.5]));
        // Up from below the plane: no crossing downward.
        assert!(!r.reads(Some([1.0, 1.0, -2.0]), &[1.0, 1.0, -3.0]));
        assert!(!r.reads(None, &[3.0, 1.0, -1.5]));
    }
}
