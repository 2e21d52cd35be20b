//! The traversability graph: one node per reachable surface patch.
//!
//! Growth starts at the rover's patch and visits the 8 neighbouring cells
//! of every traversable node in breadth-first order; in each it takes the
//! horizontal patch nearest in height within `max_step_m`, so a floor and
//! the deck above it never connect except through a ramp. Obstacle and
//! unknown nodes are leaves. Node numbers follow the growth, which depends
//! only on the map: the same map and start give the same graph.
//!
//! Classes:
//! - *unknown*: fewer than `min_inliers` support points fit a plane;
//! - *obstacle*: the plane is too steep, two neighbouring ground cells
//!   under the footprint differ by more than a step, the footprint hangs
//!   over a drop or a deep drop lies within `drop_clearance_m`, or
//!   something lies in
//!   the body's height band within the inscribed circle (where the body is
//!   in every orientation);
//! - *frontier*: traversable, with a neighbouring cell that has no patch
//!   near its height at all (unobserved space);
//! - *explorable*: traversable, next to an unknown node;
//! - *traversable*: the rest.

use std::cell::Cell;
use std::collections::VecDeque;

use speleo_mapping::mls::{drop_at, ground_near, CellSlot, MlsMap, Patch, PatchKind};
use thiserror::Error;

use crate::blocked::Blocked;
use crate::cell_heads::CellHeads;
use crate::params::TravParams;
use crate::plane;

/// No node.
pub const NONE: u32 = u32::MAX;
/// Tall cells in a row that growth crosses on their tops (see
/// `TravMap::top_of_tall`). A crack in the floor this wide (0.3 m at
/// 0.1 m cells) looks the same and is crossed too: less than the
/// leg-wheels' 0.38 m diameter.
const TALL_CELLS: i32 = 3;
/// Cells of a line out of a node looked up together (see
/// `TravMap::fetch_line`): a 0.6 m gap bridged at 0.1 m cells.
const LINE_CELLS: usize = 8;

/// The 8 neighbours, counter-clockwise from +x.
pub const NEIGHBOURS: [(i32, i32); 8] = [
    (1, 0),
    (1, 1),
    (0, 1),
    (-1, 1),
    (-1, 0),
    (-1, -1),
    (0, -1),
    (1, -1),
];

/// Points a plane fit tests for one work unit of [`TravMap::grow`]: a
/// point's distance to a candidate plane costs about what looking at a
/// few patches does.
pub const FIT_POINTS_PER_UNIT: usize = 8;

/// Work units of setting a node's final class (its eight neighbours read).
const FINISH_UNITS: u64 = 4;

/// Cells under a footprint that must show a drop for it to hang over one:
/// an edge crosses the footprint's rim in several, noise in one.
const MIN_DROP_CELLS: usize = 3;
/// A footprint cell a ray crossed at height `u` without meeting ground
/// (an open edge nothing under it is seen from: a roof's rim) is a drop
/// where ground is expected at `u` less this or over it, m: the noise
/// of the node's and the mark's heights. Ground a few centimetres under
/// `u` is no edge: past a crest, rays land that much farther and leave
/// cells empty.
const UNSEEN_TOLERANCE_M: f32 = 0.015;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TravClass {
    Traversable,
    Obstacle,
    Unknown,
    Explorable,
    Frontier,
}

impl TravClass {
    /// The robot may stand here.
    pub fn is_drivable(self) -> bool {
        matches!(
            self,
            TravClass::Traversable | TravClass::Explorable | TravClass::Frontier
        )
    }
}

/// One patch of the graph.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    pub ix: i32,
    pub iy: i32,
    /// Height of the patch (its mean); `ground_z` is the support plane's
    /// height at the cell centre (the patch mean when there is no plane).
    pub patch_z: f32,
    pub ground_z: f32,
    pub class: TravClass,
    /// Why it is an obstacle (empty otherwise).
    pub blocked: Blocked,
    pub slope_deg: f32,
    /// Unit normal of the support plane (up when there is none).
    pub normal: [f32; 3],
    /// Neighbours in [`NEIGHBOURS`] order, [`NONE`] where there is none.
    pub neighbours: [u32; 8],
    /// Some neighbouring cell has nothing near this height.
    pub touches_unobserved: bool,
    /// The node limit refused a neighbour of it: a full graph stops here,
    /// the map does not (like a growth window's border).
    pub cut: bool,
    /// The growth window refused a neighbour of it: a larger window would
    /// link on from here.
    pub window_edge: bool,
}

#[derive(Debug, Error, PartialEq)]
pub enum BuildError {
    #[error("invalid traversability parameters: {0}")]
    Params(String),
    #[error("no ground patch within a step of the start ({x:.2}, {y:.2}, {z:.2})")]
    NoStartPatch { x: f64, y: f64, z: f64 },
}

/// What a build did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BuildStats {
    pub nodes: usize,
    pub traversable: usize,
    pub obstacle: usize,
    pub unknown: usize,
    pub explorable: usize,
    pub frontier: usize,
    /// The node limit stopped the growth.
    pub full: bool,
}

/// The traversability graph; see the module documentation.
pub struct TravMap {
    params: TravParams,
    resolution: f64,
    nodes: Vec<Node>,
    /// First node of each cell; the others follow through `next_in_cell`.
    by_cell: CellHeads,
    next_in_cell: Vec<u32>,
    queue: VecDeque<u32>,
    /// Scratch: the support points of one footprint, and their heights
    /// on the footprint's square grid (NaN where none).
    support: Vec<[f64; 3]>,
    heights: Vec<f32>,
    /// Scratch: the map's slots of the footprint's cells around the node
    /// under way, on the same square grid (see [`Footprint`]).
    foot: Vec<Looked>,
    footprint: Option<Footprint>,
    stats: BuildStats,
    /// The growth is kept to these cells.
    window: Option<Window>,
    /// Nodes whose final class is set, once the queue is empty.
    finished: usize,
    complete: bool,
    /// Work done since the growth began (see [`grow`](Self::grow)).
    work: Cell<u64>,
}

/// The node whose footprint `TravMap::foot` holds, and its reach in cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Footprint {
    ix: i32,
    iy: i32,
    reach: i32,
}

/// A footprint cell's lookup in the map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Looked {
    /// Outside the footprint's circle: not looked up.
    No,
    Unknown,
    At(CellSlot),
}

/// A rectangle of cells, inclusive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub min: (i32, i32),
    pub max: (i32, i32),
}

impl Window {
    /// The square of cells within `half_width_m` of `(x, y)` (in x and y).
    pub fn around(x: f64, y: f64, half_width_m: f64, resolution_m: f64) -> Window {
        let c = |v: f64| (v / resolution_m).floor() as i32;
        Window {
            min: (c(x - half_width_m), c(y - half_width_m)),
            max: (c(x + half_width_m), c(y + half_width_m)),
        }
    }

    /// Cells it holds.
    pub fn cells(&self) -> usize {
        let w = (self.max.0 as i64 - self.min.0 as i64 + 1).max(0) as usize;
        let h = (self.max.1 as i64 - self.min.1 as i64 + 1).max(0) as usize;
        w * h
    }
}

impl TravMap {
    /// Storage for `params.max_nodes` nodes, taken now.
    pub fn new(params: TravParams) -> Result<Self, BuildError> {
        params.check().map_err(BuildError::Params)?;
        let n = params.max_nodes;
        Ok(TravMap {
            resolution: 0.1,
            nodes: Vec::with_capacity(n),
            by_cell: CellHeads::new(n, params.max_window_cells),
            next_in_cell: Vec::with_capacity(n),
            queue: VecDeque::with_capacity(n),
            support: Vec::with_capacity(1024),
            heights: Vec::with_capacity(1024),
            foot: Vec::with_capacity(1024),
            footprint: None,
            stats: BuildStats::default(),
            window: None,
            finished: 0,
            complete: false,
            work: Cell::new(0),
            params,
        })
    }

    pub fn params(&self) -> &TravParams {
        &self.params
    }

    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    pub fn node(&self, i: u32) -> Option<&Node> {
        self.nodes.get(i as usize)
    }

    pub fn stats(&self) -> BuildStats {
        self.stats
    }

    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// Centre of node `n`'s cell on its ground.
    pub fn position(&self, n: &Node) -> [f64; 3] {
        [
            (n.ix as f64 + 0.5) * self.resolution,
            (n.iy as f64 + 0.5) * self.resolution,
            n.ground_z as f64,
        ]
    }

    /// The nodes of cell `(ix, iy)`.
    pub fn nodes_in_cell(&self, ix: i32, iy: i32) -> impl Iterator<Item = u32> + '_ {
        let mut i = self.by_cell.get(ix, iy);
        std::iter::from_fn(move || {
            if i == NONE {
                return None;
            }
            let here = i;
            i = self.next_in_cell[i as usize];
            Some(here)
        })
    }

    /// The node under `(x, y)` whose ground is nearest `z` within `tol`.
    pub fn node_at(&self, x: f64, y: f64, z: f64, tol: f64) -> Option<u32> {
        let (ix, iy) = (
            (x / self.resolution).floor() as i32,
            (y / self.resolution).floor() as i32,
        );
        self.nodes_in_cell(ix, iy)
            .map(|i| (i, (self.nodes[i as usize].ground_z as f64 - z).abs()))
            .filter(|&(_, d)| d <= tol)
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
            .map(|(i, _)| i)
    }

    /// Mark every drivable node within `radius_m` of `at` (in x and y, and
    /// half a metre in height) an obstacle, except those within `spare_m`
    /// of `keep` (where the rover stands: its start must stay drivable).
    /// What the map cannot see is known this way: a rock the rover sat on,
    /// wheels spinning, is not driven over again. Returns the nodes marked.
    pub fn forbid(&mut self, at: [f64; 3], radius_m: f64, keep: [f64; 2], spare_m: f64) -> usize {
        self.forbid_where(at, radius_m, |p| {
            (p[2] - at[2]).abs() < 0.5 && (p[0] - keep[0]).hypot(p[1] - keep[1]) > spare_m
        })
    }

    /// Mark every drivable node within `radius_m` of `at` (in x and y)
    /// whose ground stands more than `rise_m` over `at`'s height an
    /// obstacle: the slope up from a place where the rover slid back or
    /// stalled climbing. The map cannot see what the ground is made of: up
    /// the lava tube's muddy entrance the rover slid off its path stop
    /// after stop where the simulation, on rock, climbed. Ground at the
    /// place and below it stays drivable (the way down). Returns the nodes
    /// marked.
    pub fn forbid_above(&mut self, at: [f64; 3], radius_m: f64, rise_m: f64) -> usize {
        self.forbid_where(at, radius_m, |p| p[2] > at[2] + rise_m)
    }

    /// Mark the drivable nodes within `radius_m` of `at` (in x and y) for
    /// which `barred` holds obstacles; how many.
    fn forbid_where(
        &mut self,
        at: [f64; 3],
        radius_m: f64,
        barred: impl Fn([f64; 3]) -> bool,
    ) -> usize {
        let res = self.resolution;
        let r = (radius_m / res).ceil() as i32;
        let (cx, cy) = ((at[0] / res).floor() as i32, (at[1] / res).floor() as i32);
        let mut marked = 0;
        for iy in cy - r..=cy + r {
            for ix in cx - r..=cx + r {
                let mut i = self.by_cell.get(ix, iy);
                while i != NONE {
                    let p = self.position(&self.nodes[i as usize]);
                    let near = (p[0] - at[0]).hypot(p[1] - at[1]) <= radius_m;
                    let n = &mut self.nodes[i as usize];
                    if near && n.class.is_drivable() && barred(p) {
                        n.class = TravClass::Obstacle;
                        n.blocked = Blocked::FORBIDDEN;
                        marked += 1;
                    }
                    i = self.next_in_cell[i as usize];
                }
            }
        }
        marked
    }

    /// Grow the graph over `mls` from the ground patch under `start`
    /// (x, y and the ground height, within a step). Replaces the previous
    /// graph; allocates nothing while the node limit holds.
    pub fn build(&mut self, mls: &MlsMap, start: [f64; 3]) -> Result<BuildStats, BuildError> {
        self.build_from(mls, &[start])
    }

    /// Start a growth from the ground patch under `start`, kept to the
    /// cells of `window` when one is given; [`grow`](Self::grow) does the
    /// work in bounded slices. The previous graph is dropped.
    pub fn begin(
        &mut self,
        mls: &MlsMap,
        start: [f64; 3],
        window: Option<Window>,
    ) -> Result<(), BuildError> {
        self.begin_from(mls, &[start], window)
    }

    /// Build the graph grown from the ground under each of `starts`
    /// together: the ground reachable from any of them, each patch once.
    /// Starts with no ground within a step are passed over; the error
    /// names the first start when none has any.
    pub fn build_from(
        &mut self,
        mls: &MlsMap,
        starts: &[[f64; 3]],
    ) -> Result<BuildStats, BuildError> {
        self.begin_from(mls, starts, None)?;
        while !self.grow(mls, u64::MAX) {}
        Ok(self.stats)
    }

    /// [`begin`](Self::begin) from several starts (see
    /// [`build_from`](Self::build_from)).
    pub fn begin_from(
        &mut self,
        mls: &MlsMap,
        starts: &[[f64; 3]],
        window: Option<Window>,
    ) -> Result<(), BuildError> {
        self.nodes.clear();
        self.by_cell.reset(window);
        self.next_in_cell.clear();
        self.queue.clear();
        self.finished = 0;
        self.complete = false;
        self.work.set(0);
        self.footprint = None;
        self.stats = BuildStats::default();
        self.resolution = mls.params().resolution_m;
        self.window = window;
        for start in starts {
            let (ix, iy) = mls.cell_of(start[0], start[1]);
            if !self.in_window(ix, iy) {
                continue;
            }
            let Some(z) = ground_near(mls.cell(ix, iy), start[2] as f32, self.params.max_step_m)
            else {
                continue;
            };
            // Two starts over one patch seed it once.
            let seeded = self
                .nodes_in_cell(ix, iy)
                .any(|i| self.nodes[i as usize].patch_z == z);
            if !seeded {
                if let Some(i) = self.add_node(ix, iy, z) {
                    self.queue.push_back(i);
                }
            }
        }
        if self.nodes.is_empty() {
            let s = starts.first().copied().unwrap_or([f64::NAN; 3]);
            return Err(BuildError::NoStartPatch {
                x: s[0],
                y: s[1],
                z: s[2],
            });
        }
        Ok(())
    }

    /// Classify and expand nodes (then set their final classes) until
    /// `work` units are spent, or the node under way is done; true once
    /// the graph is complete. A unit is a cell read or a patch looked at
    /// in it, [`FIT_POINTS_PER_UNIT`] points tested by a plane fit, a
    /// fourth of setting a node's final class: a node among a cave wall's stacks of patches
    /// costs several times one on open floor, and growth sliced by nodes
    /// took from 0.2 to 1.6 ms a slice. The same map and start give the
    /// same slices. `mls` should be the map the growth began on: one that
    /// changes between slices (the planner's, as keyframes arrive) gives a
    /// graph whose nodes were classified on different states of it, still
    /// linked consistently.
    pub fn grow(&mut self, mls: &MlsMap, work: u64) -> bool {
        let until = self.work.get().saturating_add(work.max(1));
        while self.work.get() < until && !self.complete {
            if let Some(i) = self.queue.pop_front() {
                self.expand(mls, i);
            } else if self.finished < self.nodes.len() {
                self.finish_class(self.finished);
                self.finished += 1;
                self.spend(FINISH_UNITS);
            } else {
                self.stats.nodes = self.nodes.len();
                self.complete = true;
            }
        }
        self.complete
    }

    /// Work units spent since the growth began.
    pub fn work_done(&self) -> u64 {
        self.work.get()
    }

    fn spend(&self, units: u64) {
        self.work.set(self.work.get() + units);
    }

    /// The patches of a cell, counted as work.
    fn cell<'m>(&self, mls: &'m MlsMap, ix: i32, iy: i32) -> &'m [Patch] {
        let c = mls.cell(ix, iy);
        self.spend(1 + c.len() as u64);
        c
    }

    /// Look up the cells within `r2` (cells², squared) of `(ix, iy)` in
    /// the map together: every table slot is prefetched before the first
    /// is read, and every cell's patches before any is used. One at a
    /// time, each lookup missed the caches (the map is tens of megabytes)
    /// and growth spent most of its time waiting on them.
    fn fetch_footprint(&mut self, mls: &MlsMap, ix: i32, iy: i32, reach: i32, r2: f64) {
        let side = (2 * reach + 1) as usize;
        let inside = |dx: i32, dy: i32| ((dx * dx + dy * dy) as f64) <= r2;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                if inside(dx, dy) {
                    mls.prefetch_cell(ix + dx, iy + dy);
                }
            }
        }
        self.foot.clear();
        self.foot.resize(side * side, Looked::No);
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                if inside(dx, dy) {
                    let at = mls.cell_slot(ix + dx, iy + dy);
                    self.foot[(dy + reach) as usize * side + (dx + reach) as usize] =
                        at.map_or(Looked::Unknown, Looked::At);
                }
            }
        }
        self.footprint = Some(Footprint { ix, iy, reach });
    }

    /// The patches of cell `(ix, iy)`, counted as work as
    /// [`cell`](Self::cell) counts them: from the footprint fetched last
    /// when it holds the cell, from the map otherwise.
    fn near_cell<'m>(&self, mls: &'m MlsMap, ix: i32, iy: i32) -> &'m [Patch] {
        match self.footprint_looked(ix, iy) {
            Some(Looked::At(slot)) => {
                let c = mls.patches_at(slot);
                self.spend(1 + c.len() as u64);
                c
            }
            Some(Looked::Unknown) => {
                self.spend(1);
                &[]
            }
            Some(Looked::No) | None => self.cell(mls, ix, iy),
        }
    }

    /// The footprint's lookup of cell `(ix, iy)`; None outside its square.
    fn footprint_looked(&self, ix: i32, iy: i32) -> Option<Looked> {
        let f = self.footprint?;
        let (dx, dy) = (ix - f.ix, iy - f.iy);
        if dx.abs() > f.reach || dy.abs() > f.reach {
            return None;
        }
        let side = (2 * f.reach + 1) as usize;
        Some(self.foot[(dy + f.reach) as usize * side + (dx + f.reach) as usize])
    }

    /// Look up together the cells `1..=k_max` steps from `n` in
    /// direction `d` (at most [`LINE_CELLS`]) that the footprint fetched
    /// last does not hold: the lines [`bridge`](Self::bridge) and
    /// [`top_of_tall`](Self::top_of_tall) walk reach up to seven cells
    /// out, and one lookup at a time each missed the caches. Work is
    /// counted as the cells are read, not here.
    fn fetch_line(
        &self,
        mls: &MlsMap,
        n: &Node,
        d: (i32, i32),
        k_max: i32,
    ) -> [Looked; LINE_CELLS] {
        let mut line = [Looked::No; LINE_CELLS];
        let k_max = k_max.min(LINE_CELLS as i32);
        let held = |k: i32| {
            self.footprint_looked(n.ix + k * d.0, n.iy + k * d.1)
                .is_some_and(|l| l != Looked::No)
        };
        for k in 1..=k_max {
            if !held(k) {
                mls.prefetch_cell(n.ix + k * d.0, n.iy + k * d.1);
            }
        }
        for k in 1..=k_max {
            if !held(k) {
                let at = mls.cell_slot(n.ix + k * d.0, n.iy + k * d.1);
                line[k as usize - 1] = at.map_or(Looked::Unknown, Looked::At);
            }
        }
        line
    }

    /// The patches of the cell `k` steps from `n` in direction `d`, read
    /// as [`near_cell`](Self::near_cell) reads them: from `line` (see
    /// [`fetch_line`](Self::fetch_line)) when it holds the cell.
    fn line_cell<'m>(
        &self,
        mls: &'m MlsMap,
        line: &[Looked; LINE_CELLS],
        n: &Node,
        d: (i32, i32),
        k: i32,
    ) -> &'m [Patch] {
        let looked = usize::try_from(k - 1)
            .ok()
            .and_then(|i| line.get(i))
            .copied()
            .unwrap_or(Looked::No);
        match looked {
            Looked::At(slot) => {
                let c = mls.patches_at(slot);
                self.spend(1 + c.len() as u64);
                c
            }
            Looked::Unknown => {
                self.spend(1);
                &[]
            }
            Looked::No => self.near_cell(mls, n.ix + k * d.0, n.iy + k * d.1),
        }
    }

    /// Whether the last growth is complete.
    pub fn is_complete(&self) -> bool {
        self.complete
    }

    fn in_window(&self, ix: i32, iy: i32) -> bool {
        self.window
            .is_none_or(|w| ix >= w.min.0 && iy >= w.min.1 && ix <= w.max.0 && iy <= w.max.1)
    }

    /// Classify node `i` and link it to its neighbours, queueing new ones.
    fn expand(&mut self, mls: &MlsMap, i: u32) {
        self.classify(mls, i);
        let n = self.nodes[i as usize];
        if !n.class.is_drivable() {
            self.footprint = None;
            return;
        }
        for (k, (dx, dy)) in NEIGHBOURS.iter().enumerate() {
            let (jx, jy) = (n.ix + dx, n.iy + dy);
            if !self.in_window(jx, jy) {
                self.nodes[i as usize].window_edge = true;
                continue;
            }
            let cell = self.near_cell(mls, jx, jy);
            let z = match ground_near(cell, n.patch_z, self.params.max_step_m) {
                Some(z) => z,
                // A wall or a drop seen there: no link, unless it is ground
                // with more seen beneath it.
                None if occupied_near(cell, n.patch_z, &self.params) => {
                    match self.top_of_tall(mls, &n, (*dx, *dy)) {
                        Some(z) => z,
                        None => continue,
                    }
                }
                // Nothing seen: bridged if ground lies a little further on.
                None => match self.bridge(mls, &n, (*dx, *dy)) {
                    Some(z) => z,
                    None => {
                        self.nodes[i as usize].touches_unobserved = true;
                        continue;
                    }
                },
            };
            let j = match self.find(jx, jy, z) {
                Some(j) => j,
                None => match self.add_node(jx, jy, z) {
                    Some(j) => {
                        self.queue.push_back(j);
                        j
                    }
                    None => {
                        self.stats.full = true;
                        self.nodes[i as usize].cut = true;
                        continue;
                    }
                },
            };
            self.nodes[i as usize].neighbours[k] = j;
            self.nodes[j as usize].neighbours[(k + 4) % 8] = i;
        }
        // The next node is looked up anew, perhaps in another call (and
        // map).
        self.footprint = None;
    }

    /// The node of a cell at a height (within a step: patches of one cell
    /// lie farther apart than that, bridged heights are interpolated).
    fn find(&self, ix: i32, iy: i32, z: f32) -> Option<u32> {
        self.nodes_in_cell(ix, iy)
            .find(|&i| (self.nodes[i as usize].patch_z - z).abs() <= self.params.max_step_m)
    }

    /// The height for the unobserved cell next to `n` in direction `d`:
    /// interpolated towards the first ground patch further on within
    /// `max_gap_m` (a step per cell at most), if nothing else is seen on
    /// the way. Sparse LiDAR rings leave such gaps in the ground; the
    /// support plane of the bridged node must still fit real points.
    fn bridge(&self, mls: &MlsMap, n: &Node, d: (i32, i32)) -> Option<f32> {
        let cells = (self.params.max_gap_m / self.resolution).floor() as i32;
        let line = self.fetch_line(mls, n, d, cells + 1);
        for k in 2..=cells + 1 {
            let cell = self.line_cell(mls, &line, n, d, k);
            let tol = self.params.max_step_m * k as f32;
            if let Some(g) = ground_near(cell, n.patch_z, tol) {
                return Some(n.patch_z + (g - n.patch_z) / k as f32);
            }
            if occupied_near(cell, n.patch_z, &self.params) {
                return None;
            }
        }
        None
    }

    /// The height for the cell next to `n` in direction `d` when its one
    /// tall patch is ground at `n`'s height with more seen beneath it: the
    /// low end of a ramp's slab where the floor shows under it, which the
    /// MLS merges into one patch (the two lie within its gap). Its top,
    /// when that is within a step of `n` and ground carries on within a
    /// step a cell from it, after at most [`TALL_CELLS`] such cells; a
    /// ledge's rim has nothing beyond at its height and stays a wall.
    fn top_of_tall(&self, mls: &MlsMap, n: &Node, d: (i32, i32)) -> Option<f32> {
        let step = self.params.max_step_m;
        let line = self.fetch_line(mls, n, d, TALL_CELLS + 1);
        let tall_top = |k: i32, z: f32| {
            self.line_cell(mls, &line, n, d, k)
                .iter()
                .find(|q| q.kind == PatchKind::Vertical && (q.max - z).abs() <= step)
                .map(|q| q.max)
        };
        let first = tall_top(1, n.patch_z)?;
        let mut z = first;
        for k in 2..=TALL_CELLS + 1 {
            if ground_near(self.line_cell(mls, &line, n, d, k), z, step).is_some() {
                return Some(first);
            }
            z = tall_top(k, z)?;
        }
        None
    }

    fn add_node(&mut self, ix: i32, iy: i32, patch_z: f32) -> Option<u32> {
        if self.nodes.len() >= self.params.max_nodes {
            return None;
        }
        let i = self.nodes.len() as u32;
        self.nodes.push(Node {
            ix,
            iy,
            patch_z,
            ground_z: patch_z,
            class: TravClass::Unknown,
            blocked: Blocked::NONE,
            slope_deg: 0.0,
            normal: [0.0, 0.0, 1.0],
            neighbours: [NONE; 8],
            touches_unobserved: false,
            cut: false,
            window_edge: false,
        });
        let head = self.by_cell.push_front(ix, iy, i);
        self.next_in_cell.push(head);
        Some(i)
    }

    /// Support plane, steps and body check of node `i`.
    fn classify(&mut self, mls: &MlsMap, i: u32) {
        let p = &self.params;
        let n = self.nodes[i as usize];
        let res = self.resolution;
        let (cx, cy) = ((n.ix as f64 + 0.5) * res, (n.iy as f64 + 0.5) * res);
        // Ground within the footprint: the horizontal patch of each cell
        // nearest this one's height, within the height the slope limit
        // allows over the radius.
        let reach = (p.footprint_radius_m / res).ceil() as i32;
        let r2 = (p.footprint_radius_m / res).powi(2) + 1e-6;
        let band =
            p.max_step_m + (p.footprint_radius_m * p.max_slope_deg.to_radians().tan()) as f32;
        let side = (2 * reach + 1) as usize;
        self.support.clear();
        self.heights.clear();
        self.heights.resize(side * side, f32::NAN);
        self.fetch_footprint(mls, n.ix, n.iy, reach, r2);
        let p = &self.params;
        let mut raised = false;
        let mut drops = 0usize;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                if ((dx * dx + dy * dy) as f64) > r2 {
                    continue;
                }
                let (x, y) = (cx + dx as f64 * res, cy + dy as f64 * res);
                let cell = self.near_cell(mls, n.ix + dx, n.iy + dy);
                if let Some(g) = ground_near(cell, n.patch_z, band) {
                    if self.support.len() < self.support.capacity() {
                        self.support.push([x, y, g as f64]);
                        self.heights[(dy + reach) as usize * side + (dx + reach) as usize] = g;
                    }
                } else {
                    // Ground too high to be this one's continuation, under
                    // the body: a ledge the wheels meet.
                    raised |= cell.iter().any(|q| {
                        q.kind == PatchKind::Horizontal
                            && q.mean > n.patch_z + band
                            && q.mean <= n.patch_z + p.robot_height_m
                    });
                    // The footprint hangs over a drop (a ramp's open
                    // side, a ledge's rim): the garage's rover, whose
                    // path hugged a ramp's edge, fell off it. A cell with
                    // nothing in it that a ray crossed at the node's
                    // height or under it without meeting ground is one
                    // too: a roof's rim with nothing seen under it.
                    //
                    // Half-way up the garage's roof ramp, cells down the
                    // slope whose top the rings missed hold the slab's
                    // underside a slab and the slope's fall under the
                    // node, beyond the band, over the floor under the
                    // ramp: a drop that ends the graph. Judging cells
                    // seen only from below at the plane's height took the
                    // rover to the roof, but stranded the lava tube's on
                    // the slope behind its start: not done.
                    let unseen = cell.is_empty()
                        && mls
                            .unseen_ground(n.ix + dx, n.iy + dy)
                            .is_some_and(|u| n.patch_z >= u - UNSEEN_TOLERANCE_M);
                    drops += (unseen || drop_at(cell, n.patch_z, band)) as usize;
                }
            }
        }
        let seed = ((n.ix as u32 as u64) << 32 | n.iy as u32 as u64) ^ n.patch_z.to_bits() as u64;
        self.spend((self.support.len() * p.ransac_iterations / FIT_POINTS_PER_UNIT) as u64);
        let fitted = plane::fit(
            &self.support,
            seed,
            p.ransac_iterations,
            p.inlier_distance_m as f64,
            p.min_inliers,
        );
        let Some(pl) = fitted else {
            self.nodes[i as usize].class = TravClass::Unknown;
            return;
        };
        self.heights_near_plane(mls, &n, &pl, reach);
        let p = &self.params;
        let step = has_step(&self.heights, side, p.max_step_m);
        let steep = pl.slope_deg() > p.max_slope_deg;
        // A drop is an edge: cells of it along the footprint's rim, not one
        // cell (a fleck of floor seen through a crack, a double floor).
        let dropped = drops >= MIN_DROP_CELLS;
        let mut why = Blocked::NONE
            .with(Blocked::STEEP, steep)
            .with(Blocked::STEP, step)
            .with(Blocked::RAISED, raised)
            .with(Blocked::DROP, dropped);
        if why.is_empty() {
            let deep = self.deep_drop_near(mls, &n, band);
            why = why.with(Blocked::DROP, deep);
        }
        if why.is_empty() {
            why = why.with(Blocked::BODY, self.body_hits(mls, n.ix, n.iy, &pl));
        }
        let blocked = !why.is_empty();
        let node = &mut self.nodes[i as usize];
        node.blocked = why;
        node.ground_z = pl.z_at(cx, cy) as f32;
        node.slope_deg = pl.slope_deg() as f32;
        node.normal = pl.normal().map(|v| v as f32);
        node.class = if blocked {
            TravClass::Obstacle
        } else {
            TravClass::Traversable
        };
    }

    /// A footprint cell's ground height that is a thin slab's mean off the
    /// support plane `pl` becomes the slab's top where that lies nearer
    /// the plane ([`Patch::other_ground`]): the footprint's ground is
    /// taken nearest the node's height, and across a slope a cell's mean
    /// may be the nearer while the ground around says the top is the
    /// ground the wheels meet. Only such cells: taking every cell's ground
    /// nearest the plane smoothed steps away, and the lava tube's rover
    /// was stuck 95 m in for good.
    fn heights_near_plane(&mut self, mls: &MlsMap, n: &Node, pl: &plane::Plane, reach: i32) {
        let res = self.resolution;
        let (cx, cy) = ((n.ix as f64 + 0.5) * res, (n.iy as f64 + 0.5) * res);
        let side = (2 * reach + 1) as usize;
        let on_plane = self.params.inlier_distance_m;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let k = (dy + reach) as usize * side + (dx + reach) as usize;
                let h = self.heights[k];
                // NaN where the cell has no ground (or lies off the disc).
                if h.is_nan() {
                    continue;
                }
                let want = pl.z_at(cx + dx as f64 * res, cy + dy as f64 * res) as f32;
                let off = (h - want).abs();
                if off.is_nan() || off <= on_plane {
                    continue;
                }
                let cell = self.near_cell(mls, n.ix + dx, n.iy + dy);
                let top = cell
                    .iter()
                    .filter(|q| q.ground() == Some(h))
                    .find_map(Patch::other_ground)
                    .filter(|t| (t - want).abs() < off);
                if let Some(t) = top {
                    self.heights[k] = t;
                }
            }
        }
    }

    /// Whether the ring of cells at `drop_clearance_m` from node `n` (one
    /// cell wide) shows a drop at least `deep_drop_m` deep in
    /// [`MIN_DROP_CELLS`] cells or more: an open edge the rover would pass
    /// closer than the footprint check sees, but not so close that its
    /// wheels run on the rim. Only the ring is looked at: beyond an edge
    /// nearer than it, the drop crosses the ring too.
    fn deep_drop_near(&self, mls: &MlsMap, n: &Node, band: f32) -> bool {
        let p = &self.params;
        if p.drop_clearance_m <= p.footprint_radius_m {
            return false;
        }
        let res = self.resolution;
        let outer = p.drop_clearance_m / res;
        let inner = (outer - 1.0).max(p.footprint_radius_m / res);
        let (r2_out, r2_in) = (outer * outer + 1e-6, inner * inner + 1e-6);
        let reach = outer.ceil() as i32;
        let in_ring = |dx: i32, dy: i32| {
            let d2 = (dx * dx + dy * dy) as f64;
            d2 > r2_in && d2 <= r2_out
        };
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                if in_ring(dx, dy) {
                    mls.prefetch_cell(n.ix + dx, n.iy + dy);
                }
            }
        }
        let floor = n.patch_z - p.deep_drop_m;
        let mut drops = 0usize;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                if !in_ring(dx, dy) {
                    continue;
                }
                let cell = self.cell(mls, n.ix + dx, n.iy + dy);
                let deep = cell
                    .iter()
                    .any(|q| q.max < floor && !q.underside_for(n.patch_z));
                if deep && drop_at(cell, n.patch_z, band) {
                    drops += 1;
                    if drops >= MIN_DROP_CELLS {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Whether anything lies in the body's height band over the plane
    /// within the inscribed circle.
    fn body_hits(&self, mls: &MlsMap, ix: i32, iy: i32, pl: &plane::Plane) -> bool {
        let p = &self.params;
        let res = self.resolution;
        let reach = (p.inscribed_radius_m / res).ceil() as i32;
        let r2 = (p.inscribed_radius_m / res).powi(2) + 1e-6;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                if ((dx * dx + dy * dy) as f64) > r2 {
                    continue;
                }
                let (x, y) = (
                    (ix + dx) as f64 * res + res / 2.0,
                    (iy + dy) as f64 * res + res / 2.0,
                );
                let g = pl.z_at(x, y) as f32;
                let (lo, hi) = (g + p.ground_clearance_m, g + p.robot_height_m);
                if self
                    .near_cell(mls, ix + dx, iy + dy)
                    .iter()
                    .any(|q| q.solid_max() >= lo && q.min <= hi)
                {
                    return true;
                }
            }
        }
        false
    }

    /// Frontier or explorable for node `i`, from its neighbourhood; its
    /// final class counted.
    fn finish_class(&mut self, i: usize) {
        let n = self.nodes[i];
        let class = if n.class != TravClass::Traversable {
            n.class
        } else if n.touches_unobserved {
            TravClass::Frontier
        } else if n
            .neighbours
            .iter()
            .any(|&j| j != NONE && self.nodes[j as usize].class == TravClass::Unknown)
        {
            TravClass::Explorable
        } else {
            TravClass::Traversable
        };
        self.nodes[i].class = class;
        let s = &mut self.stats;
        match class {
            TravClass::Traversable => s.traversable += 1,
            TravClass::Obstacle => s.obstacle += 1,
            TravClass::Unknown => s.unknown += 1,
            TravClass::Explorable => s.explorable += 1,
            TravClass::Frontier => s.frontier += 1,
        }
    }
}

/// Whether two side-by-side ground cells of the footprint differ by more
/// than a step (a ledge or a rock; a smooth change of slope is not one).
fn has_step(heights: &[f32], side: usize, max_step: f32) -> bool {
    let at = |x: usize, y: usize| heights[y * side + x];
    (0..side).any(|y| {
        (0..side).any(|x| {
            let h = at(x, y);
            let right = x + 1 < side && (at(x + 1, y) - h).abs() > max_step;
            let up = y + 1 < side && (at(x, y + 1) - h).abs() > max_step;
            // NaN compares false: cells without ground never count.
            right || up
        })
    })
}

/// Whether a cell holds anything between a metre below `z` and the
/// robot's height above it (a wall or a drop seen, rather than nothing
/// seen). An underside seen only from below is not a drop seen.
fn occupied_near(cell: &[Patch], z: f32, p: &TravParams) -> bool {
    let (lo, hi) = (z - 1.0, z + p.robot_height_m);
    cell.iter()
        .any(|q| q.max >= lo && q.min <= hi && !q.underside_for(z))
}
