//! The map: parameters, insertion, queries, eviction.

use nalgebra::Isometry3;

use super::index::{CellIndex, Probe};
use super::patch::{self, CellRule, CellUpdate, Patch};
use crate::{floor_i32, floor_small, prefetch, resident_buffer, ParamsError};

/// Cells beyond this many from the origin (along x or y) are out of range:
/// keeps cell coordinates and their arithmetic far from `i32` overflow.
const MAX_CELL_COORD: f64 = (1u32 << 30) as f64;
/// Heights beyond this (m) are out of range (f32 storage keeps ~0.1 mm
/// precision up to here).
const MAX_HEIGHT_M: f64 = 1.0e3;
/// Patches per cell are stored in a fixed stride of at most this many.
pub const MAX_PATCHES_PER_CELL: usize = 16;
/// Cells a map may hold: cell numbers fit in `u32` with room for the empty
/// marker, and the table size cannot overflow.
pub const MAX_CELLS: usize = 1 << 28;

/// Points in flight in the insertion pipeline (a power of two).
const RING: usize = 32;
/// How many points ahead of its update a point's table slot is prefetched.
const SLOT_AHEAD: usize = 16;
/// How many points ahead of its update a point's cell is looked up and its
/// patches prefetched (after the slot has arrived).
const CELL_AHEAD: usize = 8;
const _: () = assert!(CELL_AHEAD < SLOT_AHEAD && SLOT_AHEAD < RING);

/// Cell marks of a point in the pipeline, beyond any cell number.
const UNKNOWN: u32 = u32::MAX;
const OUT_OF_RANGE: u32 = u32::MAX - 1;
const NON_FINITE: u32 = u32::MAX - 2;

/// A point in the insertion pipeline: its cell coordinates, height, table
/// slot where the search for its cell starts, and its cell number once
/// found (or a mark).
#[derive(Clone, Copy, Default)]
struct Pending {
    ix: i32,
    iy: i32,
    z: f32,
    /// The sensor was at or over the point.
    from_above: bool,
    home: u32,
    cell: u32,
}

/// Settings of a multi-level surface map.
#[derive(Clone, Debug, PartialEq)]
pub struct MlsParams {
    /// Cell side (m).
    pub resolution_m: f64,
    /// Cells the table holds (at most [`MAX_CELLS`]); when full, points
    /// falling in new cells are dropped and counted.
    pub max_cells: usize,
    /// Surface patches a cell holds (at most [`MAX_PATCHES_PER_CELL`]); a
    /// point that would need one more is dropped and counted.
    pub max_patches_per_cell: usize,
    /// Points farther than this in height from a patch's interval belong to
    /// another level (m).
    pub gap_m: f32,
    /// A patch whose points span more height than this is vertical (m).
    /// 0.25 by default: a 45-degree slope spans 0.1 m over a 0.1 m cell and
    /// +-3 sigma of 2 cm range noise add 0.12 m, so ground the rover can
    /// drive stays horizontal, while anything steeper than about 50 degrees
    /// (and every wall) turns vertical. Kept below `gap_m` so that a patch
    /// bridging a gap is already a wall.
    pub vertical_threshold_m: f32,
    /// Range noise of the sensor (1 sigma, m); its square is the height
    /// variance of every point (an upper bound: only a vertical ray puts
    /// all of the range error into height).
    pub range_noise_m: f32,
}

impl Default for MlsParams {
    fn default() -> Self {
        MlsParams {
            resolution_m: 0.1,
            max_cells: 1 << 18,
            max_patches_per_cell: 8,
            gap_m: 0.3,
            vertical_threshold_m: 0.25,
            range_noise_m: 0.02,
        }
    }
}

impl MlsParams {
    fn validate(&self) -> Result<(), ParamsError> {
        let positive = |v: f64, name| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ParamsError::NotPositive(name))
            }
        };
        let non_negative = |v: f32, name| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(ParamsError::Negative(name))
            }
        };
        positive(self.resolution_m, "resolution_m")?;
        non_negative(self.gap_m, "gap_m")?;
        non_negative(self.vertical_threshold_m, "vertical_threshold_m")?;
        non_negative(self.range_noise_m, "range_noise_m")
    }
}

/// What one insertion did with its points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InsertStats {
    /// Points offered.
    pub points: u64,
    /// Points merged into the map.
    pub inserted: u64,
    /// NaN or infinite points (or a non-finite pose), skipped.
    pub non_finite: u64,
    /// Points too far from the origin to index, skipped.
    pub out_of_range: u64,
    /// Points dropped: their cell already held the maximum of patches.
    pub dropped_patch_limit: u64,
    /// Points dropped: their cell was new and the table was full.
    pub dropped_map_full: u64,
}

/// The map's state and totals since construction or the last
/// [`MlsMap::clear`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MlsStats {
    /// Cells in use.
    pub cells: usize,
    /// Capacity in cells.
    pub max_cells: usize,
    /// Patches over all cells.
    pub patches: usize,
    /// Points merged into the map.
    pub inserted: u64,
    /// Points dropped for want of room: `dropped_patch_limit +
    /// dropped_map_full`.
    pub dropped_points: u64,
    pub dropped_patch_limit: u64,
    pub dropped_map_full: u64,
    pub non_finite: u64,
    pub out_of_range: u64,
    /// Every cell is in use: points in new cells are being dropped.
    pub full: bool,
    /// Marks of ground expected but not seen ([`MlsMap::mark_unseen_ground`])
    /// taken, and refused for want of a cell.
    pub unseen_marks: u64,
    pub unseen_refused: u64,
    /// Bytes of the fixed buffers (taken at construction, never grown).
    pub memory_bytes: usize,
}

/// A multi-level surface map of fixed capacity; see the [module
/// documentation](super).
pub struct MlsMap {
    params: MlsParams,
    inv_res: f64,
    rule: CellRule,
    /// Patch slots per cell.
    stride: usize,
    max_cells: usize,
    index: CellIndex,
    /// Per cell, in insertion order (compacted by eviction): coordinates,
    /// patch count, and `stride` patch slots.
    keys: Vec<(i32, i32)>,
    lens: Vec<u8>,
    patches: Vec<Patch>,
    /// Per cell, the lowest height where a ray expected ground and found
    /// none (NaN: never); read only while the cell holds no patch.
    unseen: Vec<f32>,
    unseen_marks: u64,
    unseen_refused: u64,
    cells: usize,
    patch_total: usize,
    /// Smallest and largest cell coordinates in use (x0, y0, x1, y1):
    /// region visits never look beyond them.
    bounds: Option<[i32; 4]>,
    totals: InsertStats,
}

/// A known cell's place in the map's arrays: [`MlsMap::cell_slot`] gives
/// it, [`MlsMap::patches_at`] reads the patches without looking the cell
/// up again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CellSlot(u32);

impl MlsMap {
    /// Takes all the memory the map will ever use. Fails only on a
    /// non-positive resolution or a negative gap, threshold or noise; zero
    /// capacities give a map that drops (and counts) every point.
    pub fn new(params: MlsParams) -> Result<MlsMap, ParamsError> {
        params.validate()?;
        let stride = params.max_patches_per_cell.min(MAX_PATCHES_PER_CELL);
        let max_cells = params.max_cells.min(MAX_CELLS);
        Ok(MlsMap {
            inv_res: 1.0 / params.resolution_m,
            rule: CellRule {
                gap: params.gap_m,
                vertical_threshold: params.vertical_threshold_m,
                point_variance: params.range_noise_m * params.range_noise_m,
            },
            stride,
            max_cells,
            index: CellIndex::new(max_cells),
            keys: resident_buffer(max_cells, (0, 0)),
            lens: resident_buffer(max_cells, 0),
            patches: resident_buffer(max_cells * stride, Patch::default()),
            unseen: resident_buffer(max_cells, f32::NAN),
            unseen_marks: 0,
            unseen_refused: 0,
            cells: 0,
            patch_total: 0,
            bounds: None,
            totals: InsertStats::default(),
            params,
        })
    }

    pub fn params(&self) -> &MlsParams {
        &self.params
    }

    /// Inserts a scan: `points_sensor` in the sensor frame, moved by
    /// `sensor_to_map`. Allocates nothing.
    pub fn insert_scan(
        &mut self,
        sensor_to_map: &Isometry3<f64>,
        points_sensor: &[[f32; 3]],
    ) -> InsertStats {
        let r = sensor_to_map.rotation.to_rotation_matrix();
        let m = r.matrix();
        let t = sensor_to_map.translation.vector;
        let (r00, r01, r02) = (m[(0, 0)], m[(0, 1)], m[(0, 2)]);
        let (r10, r11, r12) = (m[(1, 0)], m[(1, 1)], m[(1, 2)]);
        let (r20, r21, r22) = (m[(2, 0)], m[(2, 1)], m[(2, 2)]);
        self.insert_with(points_sensor, t.z, |p| {
            let (x, y, z) = (p[0] as f64, p[1] as f64, p[2] as f64);
            [
                r00 * x + r01 * y + r02 * z + t.x,
                r10 * x + r11 * y + r12 * z + t.y,
                r20 * x + r21 * y + r22 * z + t.z,
            ]
        })
    }

    /// Inserts points already in the map frame, of a sensor unknown: they
    /// count as seen from above. Allocates nothing.
    pub fn insert_points(&mut self, points_map: &[[f64; 3]]) -> InsertStats {
        self.insert_with(points_map, f64::INFINITY, |&q| q)
    }

    /// Inserts points already in the map frame, seen from a sensor at
    /// height `sensor_z`: those over it were seen from below (see
    /// [`Patch::underside_for`](super::Patch::underside_for)). Allocates
    /// nothing.
    pub fn insert_points_seen_from(
        &mut self,
        points_map: &[[f64; 3]],
        sensor_z: f64,
    ) -> InsertStats {
        self.insert_with(points_map, sensor_z, |&q| q)
    }

    /// Inserts `points`, mapped by `to_map`, in their order, as a software
    /// pipeline: a point's table slot is prefetched [`SLOT_AHEAD`] points
    /// before it is applied, and its cell found and that cell's patches
    /// prefetched [`CELL_AHEAD`] points before (consecutive returns of one
    /// firing land in far-apart cells). The map is the same as applying
    /// the points one after the other.
    #[inline(always)]
    fn insert_with<P>(
        &mut self,
        points: &[P],
        sensor_z: f64,
        to_map: impl Fn(&P) -> [f64; 3],
    ) -> InsertStats {
        let mut s = InsertStats::default();
        let mut ring = [Pending::default(); RING];
        let n = points.len();
        for k in 0..n + SLOT_AHEAD {
            if k < n {
                ring[k % RING] = self.locate(to_map(&points[k]), sensor_z);
            }
            if let Some(j) = (k + CELL_AHEAD).checked_sub(SLOT_AHEAD) {
                if j < n {
                    self.find_ahead(&mut ring[j % RING]);
                }
            }
            if let Some(i) = k.checked_sub(SLOT_AHEAD) {
                self.apply(&ring[i % RING], &mut s);
            }
        }
        self.add_totals(&s);
        s
    }

    /// Stage 1: the point's cell and table slot, the slot prefetched.
    #[inline(always)]
    fn locate(&self, q: [f64; 3], sensor_z: f64) -> Pending {
        // NaN fails every comparison: one test rejects NaN and infinities.
        let (fx, fy) = (q[0] * self.inv_res, q[1] * self.inv_res);
        if !(fx.abs() < MAX_CELL_COORD && fy.abs() < MAX_CELL_COORD && q[2].abs() <= MAX_HEIGHT_M) {
            let finite = q.iter().all(|v| v.is_finite());
            return Pending {
                cell: if finite { OUT_OF_RANGE } else { NON_FINITE },
                ..Pending::default()
            };
        }
        let (ix, iy) = (floor_small(fx), floor_small(fy));
        let home = self.index.home(ix, iy);
        self.index.prefetch(home);
        Pending {
            ix,
            iy,
            z: q[2] as f32,
            from_above: sensor_z >= q[2],
            cell: UNKNOWN,
            home: home as u32,
        }
    }

    /// Stage 2: the point's cell if it is already known (the slot is in
    /// cache by now), its patches prefetched.
    #[inline(always)]
    fn find_ahead(&self, p: &mut Pending) {
        if p.cell != UNKNOWN {
            return;
        }
        if let Probe::Found(c) = self.index.probe_from(p.home as usize, p.ix, p.iy) {
            p.cell = c;
            let c = c as usize;
            if let Some(len) = self.lens.get(c) {
                prefetch(len);
            }
            let base = c * self.stride;
            if let Some(first) = self.patches.get(base) {
                prefetch(first);
            }
            if let Some(second) = self.patches.get(base + 1) {
                prefetch(second);
            }
        }
    }

    /// Stage 3: the point merged into its cell (made now if it was new).
    #[inline(always)]
    fn apply(&mut self, p: &Pending, s: &mut InsertStats) {
        s.points += 1;
        let cell = match p.cell {
            OUT_OF_RANGE => {
                s.out_of_range += 1;
                return;
            }
            NON_FINITE => {
                s.non_finite += 1;
                return;
            }
            // Not found ahead: new, or made by a point since.
            UNKNOWN => match self.cell_or_new(p.home as usize, p.ix, p.iy) {
                Some(c) => c,
                None => {
                    s.dropped_map_full += 1;
                    return;
                }
            },
            c => c,
        } as usize;
        let base = cell * self.stride;
        let mut len = self.lens[cell] as usize;
        let slots = &mut self.patches[base..base + self.stride];
        match patch::insert(slots, &mut len, p.z, p.from_above, &self.rule) {
            CellUpdate::Updated { merged } => {
                self.patch_total -= merged as usize;
                s.inserted += 1;
            }
            CellUpdate::Added => {
                self.patch_total += 1;
                s.inserted += 1;
            }
            CellUpdate::Full => s.dropped_patch_limit += 1,
        }
        self.lens[cell] = len as u8;
    }

    /// The cell number of `(ix, iy)`, made if new and there is room.
    #[inline(always)]
    fn cell_or_new(&mut self, home: usize, ix: i32, iy: i32) -> Option<u32> {
        match self.index.probe_from(home, ix, iy) {
            Probe::Found(c) => Some(c),
            Probe::Vacant(at) => {
                if self.cells >= self.max_cells {
                    return None;
                }
                let c = self.cells;
                self.keys[c] = (ix, iy);
                self.lens[c] = 0;
                self.unseen[c] = f32::NAN;
                self.index.fill(at, ix, iy, c as u32);
                self.cells += 1;
                self.grow_bounds(ix, iy);
                Some(c as u32)
            }
        }
    }

    fn grow_bounds(&mut self, ix: i32, iy: i32) {
        self.bounds = Some(match self.bounds {
            None => [ix, iy, ix, iy],
            Some([x0, y0, x1, y1]) => [x0.min(ix), y0.min(iy), x1.max(ix), y1.max(iy)],
        });
    }

    fn add_totals(&mut self, s: &InsertStats) {
        let t = &mut self.totals;
        t.points += s.points;
        t.inserted += s.inserted;
        t.non_finite += s.non_finite;
        t.out_of_range += s.out_of_range;
        t.dropped_patch_limit += s.dropped_patch_limit;
        t.dropped_map_full += s.dropped_map_full;
    }

    /// The cell containing the map point `(x, y)` (saturating far from the
    /// origin; NaN gives cell 0).
    pub fn cell_of(&self, x: f64, y: f64) -> (i32, i32) {
        (floor_i32(x * self.inv_res), floor_i32(y * self.inv_res))
    }

    /// Records that a ray which would have met ground at `(x, y, z)` met
    /// none there: the cell holds nothing at `z` or over it. Kept (the
    /// lowest such height) only while the cell has no patch, and made a
    /// cell of its own if it has none yet; a patch later makes it moot. An
    /// open edge nothing under it is seen from (a roof's, a cliff's over a
    /// void) shows in the map only so. Returns whether the mark was kept.
    /// Allocates nothing.
    pub fn mark_unseen_ground(&mut self, x: f64, y: f64, z: f64) -> bool {
        let (fx, fy) = (x * self.inv_res, y * self.inv_res);
        if !(fx.abs() < MAX_CELL_COORD && fy.abs() < MAX_CELL_COORD && z.abs() <= MAX_HEIGHT_M) {
            return false;
        }
        let (ix, iy) = (floor_small(fx), floor_small(fy));
        let Some(c) = self.cell_or_new(self.index.home(ix, iy), ix, iy) else {
            self.unseen_refused += 1;
            return false;
        };
        let c = c as usize;
        if self.lens[c] != 0 {
            return false;
        }
        let z = z as f32;
        let u = &mut self.unseen[c];
        *u = if u.is_nan() { z } else { u.min(z) };
        self.unseen_marks += 1;
        true
    }

    /// The height at and over which cell `(ix, iy)` was seen to hold no
    /// ground ([`MlsMap::mark_unseen_ground`]), while it holds no patch.
    pub fn unseen_ground(&self, ix: i32, iy: i32) -> Option<f32> {
        let c = self.index.get(ix, iy)? as usize;
        let u = self.unseen[c];
        (self.lens[c] == 0 && !u.is_nan()).then_some(u)
    }

    /// Centre of cell `(ix, iy)` in the map frame.
    pub fn cell_center(&self, ix: i32, iy: i32) -> [f64; 2] {
        let r = self.params.resolution_m;
        [(ix as f64 + 0.5) * r, (iy as f64 + 0.5) * r]
    }

    /// The patches of cell `(ix, iy)`, lowest first (empty if unknown).
    pub fn cell(&self, ix: i32, iy: i32) -> &[Patch] {
        match self.index.get(ix, iy) {
            Some(c) => self.patches_of(c as usize),
            None => &[],
        }
    }

    fn patches_of(&self, c: usize) -> &[Patch] {
        let base = c * self.stride;
        &self.patches[base..base + self.lens[c] as usize]
    }

    /// Asks for the cache line where the lookup of cell `(ix, iy)` begins:
    /// a hint without effect on any result. Readers of many cells at once
    /// (the traversability graph's footprints) prefetch them all first, so
    /// that the table's cache misses overlap instead of queueing.
    #[inline(always)]
    pub fn prefetch_cell(&self, ix: i32, iy: i32) {
        self.index.prefetch(self.index.home(ix, iy));
    }

    /// Where the patches of cell `(ix, iy)` are kept, if it is known; its
    /// patches are prefetched. The slot stays valid until the map changes
    /// (the `&self` borrow sees to that within one call of the reader).
    #[inline(always)]
    pub fn cell_slot(&self, ix: i32, iy: i32) -> Option<CellSlot> {
        let c = self.index.get(ix, iy)?;
        let base = c as usize * self.stride;
        prefetch(&self.lens[c as usize]);
        // A cell's patches span two or three cache lines.
        for p in [base, base + self.stride.saturating_sub(1)] {
            if let Some(q) = self.patches.get(p) {
                prefetch(q);
            }
        }
        Some(CellSlot(c))
    }

    /// The patches of the cell at `slot` (see [`MlsMap::cell_slot`]), lowest
    /// first; none for a slot this map does not have.
    #[inline(always)]
    pub fn patches_at(&self, slot: CellSlot) -> &[Patch] {
        if (slot.0 as usize) < self.max_cells {
            self.patches_of(slot.0 as usize)
        } else {
            &[]
        }
    }

    /// Calls `f(ix, iy, patches)` for every known cell whose centre's cell
    /// lies between the cells of `min_xy` and `max_xy` (inclusive), row by
    /// row: `iy` ascending, then `ix` ascending. Costs one lookup per cell
    /// of the region, known or not.
    pub fn for_each_in_region(
        &self,
        min_xy: [f64; 2],
        max_xy: [f64; 2],
        mut f: impl FnMut(i32, i32, &[Patch]),
    ) {
        if !min_xy.iter().chain(&max_xy).all(|v| v.is_finite()) {
            return;
        }
        let Some([bx0, by0, bx1, by1]) = self.bounds else {
            return;
        };
        let (x0, y0) = self.cell_of(min_xy[0], min_xy[1]);
        let (x1, y1) = self.cell_of(max_xy[0], max_xy[1]);
        let (x0, y0, x1, y1) = (x0.max(bx0), y0.max(by0), x1.min(bx1), y1.min(by1));
        for iy in y0..=y1 {
            for ix in x0..=x1 {
                if let Some(c) = self.index.get(ix, iy) {
                    f(ix, iy, self.patches_of(c as usize));
                }
            }
        }
    }

    /// Calls `f(ix, iy, patches)` for every known cell in storage order
    /// (the order cells were first seen, kept by eviction): deterministic.
    pub fn for_each_cell(&self, mut f: impl FnMut(i32, i32, &[Patch])) {
        for c in 0..self.cells {
            let (ix, iy) = self.keys[c];
            f(ix, iy, self.patches_of(c));
        }
    }

    /// Evicts every cell whose centre is farther than `radius_m` from
    /// `center_xy`, keeping the others in their order; returns how many
    /// were evicted. Compacts the cell arrays and rebuilds the index in
    /// place: allocates nothing. A non-finite centre or radius evicts
    /// nothing.
    pub fn keep_region(&mut self, center_xy: [f64; 2], radius_m: f64) -> usize {
        if !(center_xy[0].is_finite() && center_xy[1].is_finite()) || radius_m.is_nan() {
            return 0;
        }
        let r2 = radius_m * radius_m;
        let keep_all = radius_m == f64::INFINITY;
        let mut w = 0;
        for c in 0..self.cells {
            let (ix, iy) = self.keys[c];
            let [cx, cy] = self.cell_center(ix, iy);
            let (dx, dy) = (cx - center_xy[0], cy - center_xy[1]);
            if keep_all || (radius_m >= 0.0 && dx * dx + dy * dy <= r2) {
                if w != c {
                    self.keys[w] = self.keys[c];
                    self.lens[w] = self.lens[c];
                    self.unseen[w] = self.unseen[c];
                    let s = self.stride;
                    self.patches.copy_within(c * s..(c + 1) * s, w * s);
                }
                w += 1;
            } else {
                self.patch_total -= self.lens[c] as usize;
            }
        }
        let evicted = self.cells - w;
        self.cells = w;
        self.index.clear();
        self.bounds = None;
        for c in 0..w {
            let (ix, iy) = self.keys[c];
            self.index.insert_new(ix, iy, c as u32);
            self.grow_bounds(ix, iy);
        }
        evicted
    }

    /// Empties the map and its totals (for a re-projection of every
    /// keyframe after a pose-graph correction). Allocates nothing.
    pub fn clear(&mut self) {
        self.index.clear();
        self.cells = 0;
        self.patch_total = 0;
        self.bounds = None;
        self.totals = InsertStats::default();
        self.unseen_marks = 0;
        self.unseen_refused = 0;
    }

    pub fn stats(&self) -> MlsStats {
        let t = &self.totals;
        MlsStats {
            cells: self.cells,
            max_cells: self.max_cells,
            patches: self.patch_total,
            inserted: t.inserted,
            dropped_points: t.dropped_patch_limit + t.dropped_map_full,
            dropped_patch_limit: t.dropped_patch_limit,
            dropped_map_full: t.dropped_map_full,
            non_finite: t.non_finite,
            out_of_range: t.out_of_range,
            full: self.cells >= self.max_cells,
            unseen_marks: self.unseen_marks,
            unseen_refused: self.unseen_refused,
            memory_bytes: self.index.memory_bytes()
                + self.keys.len() * std::mem::size_of::<(i32, i32)>()
                + self.lens.len()
                + self.unseen.len() * std::mem::size_of::<f32>()
                + self.patches.len() * std::mem::size_of::<Patch>(),
        }
    }
}
