//! The multi-level lattice: states are (traversability node, heading), so
//! `z` comes from the patch the rover stands on and levels over each other
//! are different states.
//!
//! A primitive is projected on the surface by walking the traversability
//! graph: its poses' cells follow each other as 8-neighbour moves, and
//! each move takes the node's link in that direction, so the path stays on
//! its level, climbs ramps and is refused where the link is missing (a
//! wall, a step, unknown ground) or the node is not drivable. The body's
//! footprint (the rectangle at every intermediate pose, precomputed once
//! per primitive as cell offsets) must find nothing the map has seen in
//! the body's height band over the support plane of the nearest path node,
//! in any of its cells (unobserved cells are free: the path's nodes carry
//! the rover). The map's occupied height intervals are copied per cell
//! into a flat table when a query is prepared. Where every node of the
//! path has room for the body's circumscribed circle (precomputed per
//! node), the rectangle is not looked at.
//!
//! Cost: travel time in milliseconds, the larger of the primitive's length
//! on the surface over the forward or backward speed and its heading change
//! over the turning speed, times the primitive's multiplier. Heuristic:
//! travel time at the forward speed over the traversability graph
//! (Dijkstra from the goal node), scaled by the smallest ratio of straight
//! to 8-neighbour length so that it never overestimates.

use std::cell::{Cell, RefCell};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

use speleo_mapping::mls::MlsMap;
use speleo_traversability::{Node, TravMap, NONE};

use crate::mprim::MprimFile;
use crate::{Lattice, INFINITE_COST};

mod validate;

/// Speeds and body of the rover. Only the keys `[planner]` has always had
/// are read and written; the rest keep their defaults.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(default, deny_unknown_fields)
)]
pub struct SurfaceParams {
    pub forward_speed_mps: f64,
    pub backward_speed_mps: f64,
    pub turn_speed_rad_s: f64,
    /// The body's rectangle (along and across the heading).
    pub body_length_m: f64,
    pub body_width_m: f64,
    /// Clearance cost: a primitive's time is multiplied by `1 + weight x
    /// (1 - d / R)`, `d` the least distance from its path to something in
    /// the body's band and `R` the body's circumscribed radius (0: off).
    pub clearance_weight: f64,
    /// Turning on a slope: a primitive's turning time is multiplied by `1 +
    /// weight x (slope - free)` where the steepest node it passes slopes
    /// more than `free` degrees. A skid-steer rover turning on a ramp
    /// scrubs its wheels sideways against gravity and slides: in the
    /// simulated garage it dug in turning on a 15 degree ramp, where it
    /// climbed the same ramp straight without trouble.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub turn_slope_free_deg: f64,
    #[cfg_attr(feature = "serde", serde(skip))]
    pub turn_slope_weight_per_deg: f64,
    /// Bump cost: a primitive's time is multiplied by `1 + weight x b^2`,
    /// `b` the tallest bump under the body along its path, from 0 at
    /// [`BUMP_FLOOR_M`] over the support plane to 1 at the traversability
    /// map's ground clearance (over that the body band refuses the node);
    /// squared, so that the map's noise costs little and a rock most.
    /// A rock just under the clearance passes the map's checks, but a
    /// leg-wheel on its flank can pivot and wedge the rover (the lava
    /// tube's rover stuck on a 0.135 m rock 77 m in); where there is room
    /// around it, the path goes round (0: off). At 10 (the navigator's)
    /// a rock 0.1 m tall costs a path 6.6 times its travel time.
    pub bump_weight: f64,
    /// Rocks the body does not pass over: a node with ground under the
    /// body's inscribed circle higher than this over the plane of the
    /// ground on the ring round it, where the wheels stand (m; see
    /// [`SurfaceLattice::rock_m`]), is not entered, except near the start
    /// (0: off). Measured over the node's support plane, as the bump cost
    /// does, a rock reads about half its height: the plane of a node on
    /// its flank or top is fitted through the rock. In the simulated lava
    /// tube the rover stuck high-centred on boulders 0.15-0.19 m tall that
    /// read 0.066-0.083 m so, under the clearance, and the bump cost let
    /// paths cross them where going round was long.
    pub max_bump_m: f64,
    /// Edge cost: a primitive's time is multiplied by `1 + weight x (1 -
    /// d / reach)`, `d` the least distance from its path to a drop the map
    /// has seen (a cell with nothing near the path node's support plane
    /// and ground seen under it) within `edge_reach_m` (0: off). The
    /// traversability map refuses a node only when its footprint hangs
    /// over a drop; a path just inside that, along a ramp's open side,
    /// has its wheels on the rim: in the simulated garage the rover,
    /// planned along ramp 1's south side, tilted 20 degrees at the edge
    /// and was stranded there. Off by default: at 2, the garage's rover no
    /// longer stranded on ramp 1's side (seed 2) but explored less in both
    /// seeds tried, and never left the floor in seed 1 (the README).
    pub edge_weight: f64,
    pub edge_reach_m: f64,
    /// Wheels over an edge: a primitive whose body rectangle, over all
    /// its poses, covers this many drop cells or more (cells with
    /// nothing near the path node's support plane and ground seen under
    /// it, as for the edge cost) is refused (0: off). The
    /// traversability map's footprint is a 0.4 m disc, inside the body's
    /// corners: in the simulated garage a plan turning at a ramp's foot
    /// put a corner 0.1 m over the ramp's open side, 0.5 m over the
    /// level below, and the rover tipped there. Off by default: at 3,
    /// garage seeds 1 and 3 stalled 2.5 m up the first ramp.
    pub body_drop_cells: u32,
}

/// Bumps lower than this over a node's support plane cost nothing: the
/// map's own roughness on smooth ground, m.
pub const BUMP_FLOOR_M: f32 = 0.04;

impl Default for SurfaceParams {
    fn default() -> Self {
        SurfaceParams {
            forward_speed_mps: 0.3,
            backward_speed_mps: 0.15,
            turn_speed_rad_s: 0.5,
            body_length_m: 0.9,
            body_width_m: 0.7,
            clearance_weight: 0.0,
            turn_slope_free_deg: 8.0,
            turn_slope_weight_per_deg: 0.5,
            bump_weight: 0.0,
            max_bump_m: 0.0,
            edge_weight: 0.0,
            edge_reach_m: 0.8,
            body_drop_cells: 0,
        }
    }
}

/// The plane `r = a + b dx + c dy` fitted by least squares to the
/// sums `m` (see `rock_under`), as `[a, b, c]`; the mean height, level,
/// where the ring's cells do not fix a tilt (fewer than three, or in a
/// line), and 0 where there are none.
fn ring_plane(m: &[f64; 9]) -> [f64; 3] {
    let [n, sx, sy, sxx, sxy, syy, sr, srx, sry] = *m;
    if n < 1.0 {
        return [0.0; 3];
    }
    let det3 = |c0: [f64; 3], c1: [f64; 3], c2: [f64; 3]| {
        c0[0] * (c1[1] * c2[2] - c2[1] * c1[2]) - c1[0] * (c0[1] * c2[2] - c2[1] * c0[2])
            + c2[0] * (c0[1] * c1[2] - c1[1] * c0[2])
    };
    // Cramer's rule on the normal equations, by columns.
    let (k0, k1, k2, rhs) = ([n, sx, sy], [sx, sxx, sxy], [sy, sxy, syy], [sr, srx, sry]);
    let d = det3(k0, k1, k2);
    if n < 3.0 || d.abs() < 1e-9 * n * n * n {
        return [sr / n, 0.0, 0.0];
    }
    [
        det3(rhs, k1, k2) / d,
        det3(k0, rhs, k2) / d,
        det3(k0, k1, rhs) / d,
    ]
}

/// A bump of `m` metres over the support plane in the lattice's units:
/// 0 at [`BUMP_FLOOR_M`] to 255 at the ground clearance `clearance_m`.
fn bump_units(m: f32, clearance_m: f32) -> u8 {
    let span = clearance_m - BUMP_FLOOR_M;
    (255.0 * ((m - BUMP_FLOOR_M) / span).clamp(0.0, 1.0)).round() as u8
}

/// The 8 neighbour moves in `speleo_traversability::map::NEIGHBOURS`
/// order.
const MOVES: [(i32, i32); 8] = speleo_traversability::map::NEIGHBOURS;

/// A primitive as the surface lattice uses it.
#[derive(Clone, Debug)]
struct SurfaceAction {
    end_theta: u32,
    /// Neighbour directions from cell to cell along the poses.
    steps: Vec<u8>,
    /// Cells the body covers, relative to the start cell, each with the
    /// index (in `steps`, 0 = the start) of the path cell nearest it.
    footprint: Vec<(i32, i32, u16)>,
    length_m: f64,
    turn_rad: f64,
    backward: bool,
    cost_mult: u32,
}

/// Where the preparation for a query is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Prep {
    /// No query (or the graph changed since).
    None,
    /// Copying the map's intervals, from this cell on.
    Solid(usize),
    /// Room for the body over each node and its circle around it.
    Clear(usize),
    /// The cost-to-go, Dijkstra from the goal.
    CostToGo,
    Ready,
}

/// The lattice over a traversability map it owns; see the module
/// documentation. Every buffer is taken at construction for the map's node
/// limit: preparing a query and searching allocate nothing.
pub struct SurfaceLattice {
    trav: TravMap,
    /// The primitives' cell size, which the graph's must match.
    res_m: f64,
    angles: u32,
    p: SurfaceParams,
    /// Per heading bin: the primitives with their cell moves and body
    /// footprints, made once.
    actions: Vec<Vec<SurfaceAction>>,
    /// Per node: nothing in the body's height band over its ground.
    body_free: Vec<bool>,
    /// Per node: nothing in the body's band over this node's support plane
    /// in any cell within the body's circumscribed circle (and a cell's
    /// margin), and no drop there when `body_drop_cells` is set, so the
    /// body fits here in any orientation and the oriented check can be
    /// skipped.
    clear: Vec<bool>,
    /// Per node: squared distance (cells) to the nearest cell within that
    /// circle with something in the body's band (`u16::MAX`: none).
    blocked_d2: Vec<u16>,
    /// Per node: squared distance (cells) to the nearest drop cell within
    /// `edge_reach_m` (`u16::MAX`: none, or the edge term is off).
    edge_d2: Vec<u16>,
    /// Per node: squared distance (cells) to the nearest drop cell within
    /// the body's circle (`u16::MAX`: none, or `body_drop_cells` is 0).
    rim_d2: Vec<u16>,
    /// Per node: the tallest bump over its support plane under the body's
    /// inscribed circle, as a fraction of the way from [`BUMP_FLOOR_M`]
    /// to the ground clearance, in 1/255 (0 with `bump_weight` 0).
    bump: Vec<u8>,
    /// Per node: the rock under the body (see [`SurfaceLattice::rock_m`])
    /// in `bump`'s units (0 with `max_bump_m` 0).
    rock: Vec<u8>,
    /// The highest rock a path may pass, in `bump`'s units (255: any).
    max_bump: u8,
    /// Squared inscribed radius of the body, cells: a node with something
    /// seen nearer collides in every orientation.
    inscribed_d2: f64,
    /// How far under a node's support plane ground must lie to make a
    /// cell a drop, m: the traversability map's band for ground that
    /// continues a node's (its step plus its slope over the footprint).
    drop_tol: f32,
    /// The start's cell: what the map shows within [`ESCAPE_CELLS`] of it
    /// does not stop a primitive (see [`SurfaceLattice::set_escape`]).
    escape: Option<(i32, i32)>,
    heuristic: Vec<u32>,
    /// The map's occupied height intervals (min, max) in each cell of the
    /// nodes' bounding box grown by the body's reach; NaN pairs are
    /// unused. `origin` is its lowest cell.
    solid: Vec<[f32; 2 * SOLID_PER_CELL]>,
    origin: (i32, i32),
    dims: (usize, usize),
    goal: (u32, u32),
    /// Any heading at the goal node will do: the goal is an extra state
    /// (number `nodes x angles`) that every heading there reaches for free.
    any_heading: bool,
    prep: Prep,
    /// Dijkstra's queue (at most one entry per link relaxed: 8 a node).
    open: BinaryHeap<Reverse<(u32, u32)>>,
    /// Scratch: the nodes an action's path visits.
    path: RefCell<Vec<u32>>,
    /// Successor work so far ([`Lattice::work`]): a path step or a
    /// footprint cell tested, one each.
    work: Cell<u64>,
    /// Since [`begin`](Self::begin), some primitive ran into the growth
    /// window's border ([`Node::window_edge`]).
    met_window_edge: Cell<bool>,
}

fn direction(dx: i32, dy: i32) -> Option<u8> {
    MOVES.iter().position(|&m| m == (dx, dy)).map(|k| k as u8)
}

/// Work units of each preparation phase: map cells copied, nodes whose
/// circle is checked, Dijkstra pops. Chosen so that a unit of each costs
/// about one expansion (~10 us on the lava tube; see the planner README).
const SOLID_PER_UNIT: usize = 128;
/// Radius around the start within which the map does not stop a
/// primitive, cells (0.3 m at 0.1 m cells).
pub const ESCAPE_CELLS: i32 = 3;
const ROOM_PER_UNIT: usize = 12;
/// With the edge term on, each node's circle is also searched for drops:
/// a node costs about half as much again (`speleo plan --world garage`:
/// 12.7 us a unit of 12 without, 19-20 us with).
const ROOM_PER_UNIT_EDGES: usize = 8;
/// With the rock limit on, each node's inscribed circle and the ring
/// round it are read again: a node costs about three quarters as much
/// again (a 20,000-node floor in the planner's tests: 25 ms a
/// preparation without, 40 ms with).
const ROOM_PER_UNIT_ROCKS: usize = 7;
/// With both.
const ROOM_PER_UNIT_EDGES_ROCKS: usize = 5;
const POPS_PER_UNIT: usize = 96;

/// Occupied intervals kept per cell; a cell with more patches has the rest
/// merged into the last.
pub const SOLID_PER_CELL: usize = 8;

impl SurfaceLattice {
    /// The lattice over `trav` (whose graph may be grown later, through
    /// [`trav_mut`](Self::trav_mut)) with the primitives `prims`, at the
    /// map's resolution, for graphs whose nodes' cells span at most
    /// `max_grid_cells` cells.
    pub fn new(
        trav: TravMap,
        prims: &MprimFile,
        p: SurfaceParams,
        max_grid_cells: usize,
    ) -> Result<Self, String> {
        let res = prims.resolution_m;
        if !(res > 0.0 && res.is_finite()) {
            return Err(format!(
                "the primitives' resolution {res} m is not positive"
            ));
        }
        let n = trav.params().max_nodes;
        if n.saturating_mul(prims.angles as usize) >= u32::MAX as usize {
            return Err("too many states: lower max_nodes".into());
        }
        let inscribed_d2 = (p.body_width_m / 2.0 / res).powi(2);
        let tp = trav.params();
        let drop_tol =
            tp.max_step_m + (tp.footprint_radius_m * tp.max_slope_deg.to_radians().tan()) as f32;
        let mut actions = vec![Vec::new(); prims.angles as usize];
        for prim in &prims.primitives {
            if let Some(a) = surface_action(prim, prims.angles, res, &p) {
                actions[prim.start_angle as usize].push(a);
            }
        }
        Ok(SurfaceLattice {
            trav,
            res_m: res,
            angles: prims.angles,
            p,
            actions,
            body_free: Vec::with_capacity(n),
            clear: Vec::with_capacity(n),
            blocked_d2: Vec::with_capacity(n),
            edge_d2: Vec::with_capacity(n),
            rim_d2: Vec::with_capacity(n),
            bump: Vec::with_capacity(n),
            rock: Vec::with_capacity(n),
            max_bump: u8::MAX,
            inscribed_d2,
            drop_tol,
            escape: None,
            heuristic: Vec::with_capacity(n),
            solid: Vec::with_capacity(max_grid_cells),
            origin: (0, 0),
            dims: (0, 0),
            goal: (0, 0),
            any_heading: false,
            prep: Prep::None,
            open: BinaryHeap::with_capacity(8 * n + 1),
            path: RefCell::new(Vec::with_capacity(256)),
            work: Cell::new(0),
            met_window_edge: Cell::new(false),
        })
    }

    pub fn trav(&self) -> &TravMap {
        &self.trav
    }

    /// The graph, to grow it again; the query must be begun again after.
    pub fn trav_mut(&mut self) -> &mut TravMap {
        self.prep = Prep::None;
        &mut self.trav
    }

    /// Most states any graph within the node limit gives (the search's
    /// storage).
    pub fn max_state_count(&self) -> usize {
        self.trav.params().max_nodes * self.angles as usize + 1
    }

    /// Heading bins.
    pub fn angles(&self) -> u32 {
        self.angles
    }

    /// Prepare a query to node `goal` at any heading (see
    /// [`begin`](Self::begin)).
    /// Let primitives pass whatever the map shows within [`ESCAPE_CELLS`]
    /// of node `start` (none: every pose is checked). The rover stands
    /// there, so it fits: what the map shows that close is its own noise, a
    /// wall the rover leans on after a slip, or the lean itself. Without
    /// this a rover stopped near a wall could never plan its way out.
    pub fn set_escape(&mut self, start: Option<u32>) {
        self.escape = start.and_then(|n| self.trav.node(n)).map(|n| (n.ix, n.iy));
    }

    fn near_escape(&self, n: &Node) -> bool {
        self.escape.is_some_and(|(ix, iy)| {
            let (dx, dy) = (n.ix - ix, n.iy - iy);
            dx * dx + dy * dy <= ESCAPE_CELLS * ESCAPE_CELLS
        })
    }

    pub fn begin_any_heading(&mut self, goal: u32) -> Result<(), String> {
        self.begin((goal, 0))?;
        self.any_heading = true;
        Ok(())
    }

    /// Prepare a query to node `goal` at heading bin `goal_theta` over the
    /// current (complete) graph, in [`prepare`](Self::prepare) steps.
    pub fn begin(&mut self, goal: (u32, u32)) -> Result<(), String> {
        self.prep = Prep::None;
        if !self.trav.is_complete() {
            return Err("the traversability graph is not complete".into());
        }
        let res = self.trav.resolution();
        if (self.res_m - res).abs() > 1e-6 * res {
            return Err(format!(
                "the primitives are for {} m cells, the map has {res} m",
                self.res_m
            ));
        }
        let nodes = self.trav.nodes();
        let n = nodes.len();
        if goal.0 as usize >= n || goal.1 >= self.angles {
            return Err(format!("no goal state ({}, {})", goal.0, goal.1));
        }
        let ((x0, y0), (x1, y1)) = grid_bounds(&self.trav, &self.p);
        let dims = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
        if dims.0 * dims.1 > self.solid.capacity() {
            return Err(format!(
                "the graph and the body's reach span {} x {} cells, more than the {} the lattice was made for",
                dims.0,
                dims.1,
                self.solid.capacity()
            ));
        }
        self.origin = (x0, y0);
        self.dims = dims;
        self.solid.clear();
        self.body_free.clear();
        self.clear.clear();
        self.blocked_d2.clear();
        self.edge_d2.clear();
        self.rim_d2.clear();
        self.bump.clear();
        self.rock.clear();
        self.max_bump = if self.p.max_bump_m > 0.0 {
            bump_units(
                self.p.max_bump_m as f32,
                self.trav.params().ground_clearance_m,
            )
        } else {
            u8::MAX
        };
        self.heuristic.clear();
        self.heuristic.resize(n, INFINITE_COST);
        self.open.clear();
        self.goal = goal;
        self.any_heading = false;
        self.met_window_edge.set(false);
        self.prep = Prep::Solid(0);
        Ok(())
    }

    /// Up to `units` units of the preparation; true once the lattice is
    /// ready to search. `mls` must be the map the graph was grown on.
    pub fn prepare(&mut self, mls: &MlsMap, units: usize) -> bool {
        for _ in 0..units.max(1) {
            self.prep = match self.prep {
                Prep::None | Prep::Ready => break,
                Prep::Solid(c) => self.copy_solid(mls, c),
                Prep::Clear(i) => {
                    let mut next = Prep::Clear(i);
                    let per_unit = match (self.p.edge_weight > 0.0, self.p.max_bump_m > 0.0) {
                        (false, false) => ROOM_PER_UNIT,
                        (true, false) => ROOM_PER_UNIT_EDGES,
                        (false, true) => ROOM_PER_UNIT_ROCKS,
                        (true, true) => ROOM_PER_UNIT_EDGES_ROCKS,
                    };
                    for k in i..i + per_unit {
                        next = self.check_circle(k);
                        if next == Prep::CostToGo {
                            break;
                        }
                    }
                    next
                }
                Prep::CostToGo => self.settle(),
            };
        }
        self.prep == Prep::Ready
    }

    /// [`begin`](Self::begin) and [`prepare`](Self::prepare) to the end.
    pub fn prepare_all(&mut self, mls: &MlsMap, goal: (u32, u32)) -> Result<(), String> {
        self.begin(goal)?;
        while !self.prepare(mls, usize::MAX) {}
        Ok(())
    }

    /// What the preparation is doing: "none", "map", "room", "cost-to-go"
    /// or "ready".
    pub fn phase(&self) -> &'static str {
        match self.prep {
            Prep::None => "none",
            Prep::Solid(_) => "map",
            Prep::Clear(_) => "room",
            Prep::CostToGo => "cost-to-go",
            Prep::Ready => "ready",
        }
    }

    /// How far the highest ground under node `node`'s inscribed circle
    /// rises over the plane fitted to the ground on a ring a cell wide
    /// round it, where the wheels stand, m (to the ground clearance; 0
    /// under [`BUMP_FLOOR_M`]), once prepared (with `max_bump_m` 0 too:
    /// read from the map's table then): what takes away the body's
    /// clearance. Unlike the bump, it does not read a rock the node
    /// stands on as ground, nor a tube's floor curving up into its wall
    /// (the ring's plane tilts with it) as a rock; a step between the
    /// wheels reads about half its height, a crest the sag of the slopes'
    /// chord under it.
    pub fn rock_m(&self, node: u32) -> Option<f32> {
        if self.prep != Prep::Ready {
            return None;
        }
        let b = match self.rock.get(node as usize) {
            Some(&b) if self.p.max_bump_m > 0.0 => b,
            _ => self.rock_under(self.trav.nodes().get(node as usize)?),
        };
        Some(self.units_m(b))
    }

    /// How many of the graph's nodes have a rock under the body higher
    /// than `max_bump_m`, once prepared.
    pub fn rocky_nodes(&self) -> usize {
        self.rock.iter().filter(|&&r| r > self.max_bump).count()
    }

    /// Whether node `node` has a rock under the body higher than
    /// `max_bump_m` (and is passed only near the start), once prepared.
    pub fn over_a_rock(&self, node: u32) -> bool {
        self.rock
            .get(node as usize)
            .is_some_and(|&r| r > self.max_bump)
    }

    /// How far the tallest bump under node `node`'s inscribed circle
    /// rises over its support plane, m (to the ground clearance; 0 under
    /// [`BUMP_FLOOR_M`], or with `bump_weight` 0), once prepared.
    pub fn bump_m(&self, node: u32) -> Option<f32> {
        let b = *self.bump.get(node as usize)?;
        Some(self.units_m(b))
    }

    /// A bump in the lattice's units in metres ([`bump_units`]'s inverse).
    fn units_m(&self, b: u8) -> f32 {
        let span = self.trav.params().ground_clearance_m - BUMP_FLOOR_M;
        if b == 0 {
            0.0
        } else {
            BUMP_FLOOR_M + span * b as f32 / 255.0
        }
    }

    pub fn is_ready(&self) -> bool {
        self.prep == Prep::Ready
    }

    fn copy_solid(&mut self, mls: &MlsMap, from: usize) -> Prep {
        let cells = self.dims.0 * self.dims.1;
        let to = (from + SOLID_PER_UNIT).min(cells);
        let at = |c: usize| {
            (
                self.origin.0 + (c % self.dims.0) as i32,
                self.origin.1 + (c / self.dims.0) as i32,
            )
        };
        // The unit's cells looked up together, their table slots and then
        // their patches prefetched first: one at a time, each lookup
        // waited on a cache miss.
        for c in from..to {
            let (ix, iy) = at(c);
            mls.prefetch_cell(ix, iy);
        }
        let mut slots = [None; SOLID_PER_UNIT];
        for (slot, c) in slots.iter_mut().zip(from..to) {
            let (ix, iy) = at(c);
            *slot = mls.cell_slot(ix, iy);
        }
        for slot in &slots[..to - from] {
            let patches = slot.map_or(&[][..], |s| mls.patches_at(s));
            let mut row = [f32::NAN; 2 * SOLID_PER_CELL];
            for (k, q) in patches.iter().enumerate() {
                let at = 2 * k.min(SOLID_PER_CELL - 1);
                if k < SOLID_PER_CELL {
                    row[at] = q.min;
                    row[at + 1] = q.max;
                } else {
                    row[at] = row[at].min(q.min);
                    row[at + 1] = row[at + 1].max(q.max);
                }
            }
            self.solid.push(row);
        }
        if to < cells {
            Prep::Solid(to)
        } else {
            Prep::Clear(0)
        }
    }

    /// Whether the map has seen nothing in the body's height band over
    /// `ground` in cell `(ix, iy)`.
    fn band_free(&self, ix: i32, iy: i32, ground: f32) -> bool {
        let (gx, gy) = (ix - self.origin.0, iy - self.origin.1);
        if gx < 0 || gy < 0 || gx as usize >= self.dims.0 || gy as usize >= self.dims.1 {
            // Beyond the body's reach from every node: never asked.
            return true;
        }
        let tp = self.trav.params();
        let (lo, hi) = (ground + tp.ground_clearance_m, ground + tp.robot_height_m);
        let row = &self.solid[gy as usize * self.dims.0 + gx as usize];
        intervals(row).all(|iv| !(iv[1] >= lo && iv[0] <= hi))
    }

    /// Whether cell `(ix, iy)` is a drop from `ground`: nothing seen near
    /// that height (within the traversability map's ground band) and
    /// something seen under it. A cell with nothing seen is no drop: what
    /// the rings missed on a ramp is not an edge, nor is a cell the graph
    /// holds a node in near that height. The traversability map's test
    /// for a footprint over a drop, out to the edge term's reach.
    fn drop_at(&self, ix: i32, iy: i32, ground: f32) -> bool {
        let (gx, gy) = (ix - self.origin.0, iy - self.origin.1);
        if gx < 0 || gy < 0 || gx as usize >= self.dims.0 || gy as usize >= self.dims.1 {
            return false;
        }
        let tol = self.drop_tol;
        let (lo, hi) = (ground - tol, ground + tol);
        let row = &self.solid[gy as usize * self.dims.0 + gx as usize];
        let mut below = false;
        for iv in intervals(row) {
            if iv[1] >= lo && iv[0] <= hi {
                return false;
            }
            below |= iv[1] < lo;
        }
        // Ground the graph bridged there (a fleck of floor seen through a
        // gap in the rings) is ground.
        below
            && !self
                .trav
                .nodes_in_cell(ix, iy)
                .any(|j| (self.trav.nodes()[j as usize].ground_z - ground).abs() <= tol)
    }

    /// Height of node `nd`'s support plane over the centre of cell
    /// `(ix, iy)`.
    fn plane_z(&self, nd: &speleo_traversability::Node, ix: i32, iy: i32) -> f32 {
        let res = self.trav.resolution() as f32;
        let [nx, ny, nz] = nd.normal;
        let nz = nz.max(0.1);
        let (dx, dy) = ((ix - nd.ix) as f32 * res, (iy - nd.iy) as f32 * res);
        nd.ground_z - (nx * dx + ny * dy) / nz
    }

    /// Whether node `i` has room for the body over it, and in every
    /// orientation around it.
    fn check_circle(&mut self, i: usize) -> Prep {
        let nodes = self.trav.nodes();
        if i >= nodes.len() {
            let g = self.goal.0;
            // A goal no primitive may end on is reached from nowhere.
            if self.enterable(g) {
                self.heuristic[g as usize] = 0;
                self.open.push(Reverse((0, g)));
            }
            return Prep::CostToGo;
        }
        let res = self.trav.resolution();
        let radius = circumscribed_radius(&self.p) + res * std::f64::consts::SQRT_2;
        let reach = (radius / res).ceil() as i32;
        let r2 = (radius / res).powi(2);
        let nd = nodes[i];
        let free = self.band_free(nd.ix, nd.iy, nd.ground_z);
        let e2 = if self.p.edge_weight > 0.0 {
            (self.p.edge_reach_m / res).powi(2)
        } else {
            -1.0
        };
        let reach = reach.max(e2.max(0.0).sqrt().ceil() as i32);
        let rims = self.p.body_drop_cells > 0;
        // The nearest cell (squared, in cells) with something in the band,
        // the nearest drop, and the nearest drop within the circle.
        let mut nearest = u16::MAX;
        let mut edge = u16::MAX;
        let mut rim = u16::MAX;
        if free {
            for dy in -reach..=reach {
                for dx in -reach..=reach {
                    let d2 = dx * dx + dy * dy;
                    let band = d2 as f64 <= r2 && d2 < nearest as i32;
                    let drop = d2 as f64 <= e2 && d2 < edge as i32;
                    let wheel = rims && d2 as f64 <= r2 && d2 < rim as i32;
                    if !band && !drop && !wheel {
                        continue;
                    }
                    let (ix, iy) = (nd.ix + dx, nd.iy + dy);
                    let ground = self.plane_z(&nd, ix, iy);
                    if band && !self.band_free(ix, iy, ground) {
                        // Something stands there: no drop.
                        nearest = d2 as u16;
                        continue;
                    }
                    if (drop || wheel) && self.drop_at(ix, iy, ground) {
                        if drop {
                            edge = d2 as u16;
                        }
                        if wheel {
                            rim = d2 as u16;
                        }
                    }
                }
            }
        } else {
            nearest = 0;
        }
        let clear = nearest == u16::MAX && rim == u16::MAX;
        let bump = if free && self.p.bump_weight > 0.0 {
            self.bump_under(&nd)
        } else {
            0
        };
        let rock = if free && self.p.max_bump_m > 0.0 {
            self.rock_under(&nd)
        } else {
            0
        };
        self.bump.push(bump);
        self.rock.push(rock);
        self.body_free.push(free);
        self.clear.push(clear);
        self.blocked_d2.push(nearest);
        self.edge_d2.push(edge);
        self.rim_d2.push(rim);
        Prep::Clear(i + 1)
    }

    /// The tallest bump under node `nd`'s inscribed circle (see
    /// [`SurfaceLattice::bump`]): the highest top of what the map holds
    /// between the support plane and the ground clearance.
    fn bump_under(&self, nd: &Node) -> u8 {
        let tp = self.trav.params();
        let reach = self.inscribed_d2.sqrt().floor() as i32;
        let mut tallest = 0.0f32;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                if (dx * dx + dy * dy) as f64 > self.inscribed_d2 {
                    continue;
                }
                let (ix, iy) = (nd.ix + dx, nd.iy + dy);
                let (gx, gy) = (ix - self.origin.0, iy - self.origin.1);
                if gx < 0 || gy < 0 || gx as usize >= self.dims.0 || gy as usize >= self.dims.1 {
                    continue;
                }
                let ground = self.plane_z(nd, ix, iy);
                let (lo, hi) = (ground + BUMP_FLOOR_M, ground + tp.ground_clearance_m);
                let row = &self.solid[gy as usize * self.dims.0 + gx as usize];
                for iv in intervals(row) {
                    // Ground-level tops only.
                    if iv[1] > lo && iv[0] < hi {
                        tallest = tallest.max(iv[1].min(hi) - lo);
                    }
                }
            }
        }
        bump_units(BUMP_FLOOR_M + tallest, tp.ground_clearance_m)
    }

    /// The rock under node `nd`'s body (see [`SurfaceLattice::rock_m`]),
    /// in `bump`'s units.
    fn rock_under(&self, nd: &Node) -> u8 {
        let inner = self.inscribed_d2;
        // The ring: a cell wide, round the inscribed circle.
        let outer = (inner.sqrt() + 1.0).powi(2);
        let reach = outer.sqrt().floor() as i32;
        // The plane of the ring's ground, by least squares in the node
        // plane's frame: sums of 1, dx, dy, dx^2, dx dy, dy^2, r, r dx,
        // r dy.
        let mut m = [0.0f64; 9];
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let d2 = (dx * dx + dy * dy) as f64;
                if d2 <= inner || d2 > outer {
                    continue;
                }
                let Some(r) = self.ground_over_plane(nd, dx, dy) else {
                    continue;
                };
                let (x, y, r) = (dx as f64, dy as f64, r as f64);
                for (k, v) in [1.0, x, y, x * x, x * y, y * y, r, r * x, r * y]
                    .into_iter()
                    .enumerate()
                {
                    m[k] += v;
                }
            }
        }
        let [a, b, c] = ring_plane(&m);
        let mut rock = 0.0f64;
        let reach = inner.sqrt().floor() as i32;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                if (dx * dx + dy * dy) as f64 > inner {
                    continue;
                }
                if let Some(r) = self.ground_over_plane(nd, dx, dy) {
                    rock = rock.max(r as f64 - (a + b * dx as f64 + c * dy as f64));
                }
            }
        }
        bump_units(rock as f32, self.trav.params().ground_clearance_m)
    }

    /// The ground in the cell at `(dx, dy)` from node `nd` over its
    /// support plane, m: the cell's highest top near the plane (what
    /// stands into the body's band counts to the band's foot); `None`
    /// where nothing was seen there.
    fn ground_over_plane(&self, nd: &Node, dx: i32, dy: i32) -> Option<f32> {
        let (ix, iy) = (nd.ix + dx, nd.iy + dy);
        let (gx, gy) = (ix - self.origin.0, iy - self.origin.1);
        if gx < 0 || gy < 0 || gx as usize >= self.dims.0 || gy as usize >= self.dims.1 {
            return None;
        }
        let ground = self.plane_z(nd, ix, iy);
        let (lo, hi) = (
            ground - self.drop_tol,
            ground + self.trav.params().ground_clearance_m,
        );
        let row = &self.solid[gy as usize * self.dims.0 + gx as usize];
        intervals(row)
            .filter(|iv| iv[1] > lo && iv[0] < hi)
            .map(|iv| iv[1].min(hi) - ground)
            .reduce(f32::max)
    }

    /// Whether a primitive may pass node `j` (drivable, with room for the
    /// body's width, or near the start): `apply`'s test, which the
    /// cost-to-go follows too.
    fn enterable(&self, j: u32) -> bool {
        let n = &self.trav.nodes()[j as usize];
        let crowded = (self.blocked_d2[j as usize] as f64) < self.inscribed_d2;
        let rocky = self.rock[j as usize] > self.max_bump;
        n.class.is_drivable() && (!(crowded || rocky) || self.near_escape(n))
    }

    /// Whether a path from `node` to the goal may exist, once prepared:
    /// false when the cost-to-go reached neither it nor a neighbour (a
    /// primitive's first step; the start itself may be crowded): the goal
    /// has no room for the body, or no corridor wide enough joins them, and
    /// a search would only use up its expansions.
    pub fn reaches(&self, node: u32) -> bool {
        let finite = |j: u32| {
            self.heuristic
                .get(j as usize)
                .is_some_and(|&h| h < INFINITE_COST)
        };
        let Some(n) = self.trav.node(node) else {
            return false;
        };
        self.prep == Prep::Ready
            && (finite(node) || n.neighbours.iter().any(|&j| j != NONE && finite(j)))
    }

    /// Whether the search since [`begin`](Self::begin) ran a primitive
    /// into the growth window's border: only then can a larger window
    /// change what it finds (within the same expansions, the same search).
    pub fn met_window_edge(&self) -> bool {
        self.met_window_edge.get()
    }

    /// A few steps of Dijkstra from the goal: travel time at the forward
    /// speed over the nodes a path may pass, ms, scaled to stay admissible.
    fn settle(&mut self) -> Prep {
        let nodes = self.trav.nodes();
        // Straight over 8-neighbour length is at least 1 / 1.0824.
        let scale = 1000.0 / self.p.forward_speed_mps / 1.0824;
        let res = self.trav.resolution();
        for _ in 0..POPS_PER_UNIT {
            let Some(Reverse((d, i))) = self.open.pop() else {
                return Prep::Ready;
            };
            if d > self.heuristic[i as usize] {
                continue;
            }
            let a = &nodes[i as usize];
            for (k, &j) in a.neighbours.iter().enumerate() {
                // Only over nodes a path may pass (`apply`'s test): a node
                // left at infinity has no path to the goal at all.
                if j == NONE || !self.enterable(j) {
                    continue;
                }
                let b = &nodes[j as usize];
                let xy = if k % 2 == 0 {
                    res
                } else {
                    res * std::f64::consts::SQRT_2
                };
                let dz = (a.ground_z - b.ground_z) as f64;
                let c = ((xy * xy + dz * dz).sqrt() * scale).floor() as u32;
                let nd = d.saturating_add(c);
                if nd < self.heuristic[j as usize] {
                    self.heuristic[j as usize] = nd;
                    self.open.push(Reverse((nd, j)));
                }
            }
        }
        Prep::CostToGo
    }

    pub fn state(&self, node: u32, theta: u32) -> u32 {
        node * self.angles + theta
    }

    pub fn decode(&self, s: u32) -> (u32, u32) {
        (s / self.angles, s % self.angles)
    }

    pub fn goal_state(&self) -> u32 {
        if self.any_heading {
            self.virtual_goal()
        } else {
            self.state(self.goal.0, self.goal.1)
        }
    }

    /// The extra state of an any-heading goal (its node decodes past the
    /// graph's nodes: it has no position).
    fn virtual_goal(&self) -> u32 {
        self.trav.nodes().len() as u32 * self.angles
    }

    /// Primitives kept per heading.
    pub fn action_count(&self) -> usize {
        self.actions.iter().map(Vec::len).sum()
    }

    /// The cost of action `a` from node `n`, and the node it ends on.
    fn apply(&self, n: u32, a: &SurfaceAction, path: &mut Vec<u32>) -> Option<(u32, u32)> {
        let nodes = self.trav.nodes();
        path.clear();
        path.push(n);
        let mut cur = n;
        let mut all_clear = self.clear[n as usize];
        let mut nearest_d2 = self.blocked_d2[n as usize];
        let mut edge_d2 = self.edge_d2[n as usize];
        let mut length_3d = 0.0;
        let mut length_xy = 0.0;
        let mut steepest_deg = nodes[n as usize].slope_deg;
        let mut bump = self.bump[n as usize];
        let res = self.trav.resolution();
        // Counted up front: an action cut short cost part of it, an action
        // that tests its footprint is counted again below.
        self.work.set(self.work.get() + a.steps.len() as u64);
        for &k in &a.steps {
            let next = nodes[cur as usize].neighbours[k as usize];
            if next == NONE {
                if nodes[cur as usize].window_edge {
                    self.met_window_edge.set(true);
                }
                return None;
            }
            if !self.enterable(next) {
                return None;
            }
            let b = &nodes[next as usize];
            let xy = if k % 2 == 0 {
                res
            } else {
                res * std::f64::consts::SQRT_2
            };
            let dz = (b.ground_z - nodes[cur as usize].ground_z) as f64;
            steepest_deg = steepest_deg.max(b.slope_deg);
            length_xy += xy;
            length_3d += (xy * xy + dz * dz).sqrt();
            cur = next;
            all_clear &= self.clear[cur as usize];
            nearest_d2 = nearest_d2.min(self.blocked_d2[cur as usize]);
            edge_d2 = edge_d2.min(self.edge_d2[cur as usize]);
            bump = bump.max(self.bump[cur as usize]);
            path.push(cur);
        }
        // The body over the plane of the nearest path node (where some
        // pose has less room than the body's circle).
        let start = &nodes[n as usize];
        let oriented = if all_clear { &[][..] } else { &a.footprint[..] };
        self.work.set(self.work.get() + oriented.len() as u64);
        let mut drops = 0u32;
        for &(ox, oy, k) in oriented {
            let at = path[(k as usize).min(path.len() - 1)] as usize;
            let nd = &nodes[at];
            if self.near_escape(nd) {
                continue;
            }
            let (ix, iy) = (start.ix + ox, start.iy + oy);
            // Every cell nearer a path node than the nearest cell with
            // something in the band and the nearest drop (within the
            // body's circle, where this cell lies) is free: most are
            // passed here.
            let (dx, dy) = (ix - nd.ix, iy - nd.iy);
            let d2 = dx * dx + dy * dy;
            let band = d2 >= self.blocked_d2[at] as i32;
            let rim = d2 >= self.rim_d2[at] as i32;
            if !band && !rim {
                continue;
            }
            let ground = self.plane_z(nd, ix, iy);
            if band && !self.band_free(ix, iy, ground) {
                return None;
            }
            if rim && self.drop_at(ix, iy, ground) {
                drops += 1;
                if drops >= self.p.body_drop_cells {
                    return None;
                }
            }
        }
        let slope_factor = if length_xy > 0.0 {
            length_3d / length_xy
        } else {
            1.0
        };
        let speed = if a.backward {
            self.p.backward_speed_mps
        } else {
            self.p.forward_speed_mps
        };
        let linear = a.length_m * slope_factor / speed;
        let over = (steepest_deg as f64 - self.p.turn_slope_free_deg).max(0.0);
        let turn =
            a.turn_rad / self.p.turn_speed_rad_s * (1.0 + self.p.turn_slope_weight_per_deg * over);
        let crowding = if nearest_d2 == u16::MAX || self.p.clearance_weight <= 0.0 {
            0.0
        } else {
            let d = (nearest_d2 as f64).sqrt() * res;
            (1.0 - d / circumscribed_radius(&self.p)).clamp(0.0, 1.0)
        };
        let b = bump as f64 / 255.0;
        let bumpy = self.p.bump_weight * b * b;
        let edgy = if edge_d2 == u16::MAX || self.p.edge_weight <= 0.0 {
            0.0
        } else {
            let d = (edge_d2 as f64).sqrt() * res;
            self.p.edge_weight * (1.0 - d / self.p.edge_reach_m).clamp(0.0, 1.0)
        };
        let time = linear.max(turn)
            * (1.0 + self.p.clearance_weight * crowding)
            * (1.0 + bumpy)
            * (1.0 + edgy);
        let ms = (1000.0 * time).ceil() as u64 * a.cost_mult as u64;
        Some((cur, ms.min(INFINITE_COST as u64 - 1) as u32))
    }

    /// The ground positions along the path of states (for reports).
    pub fn path_positions(&self, states: &[u32]) -> Vec<[f64; 3]> {
        states
            .iter()
            .filter_map(|&s| self.trav.node(self.decode(s).0))
            .map(|nd| self.trav.position(nd))
            .collect()
    }
}

/// The intervals a row of the map table holds: filled from the first
/// pair on, the unused ones NaN.
fn intervals(row: &[f32; 2 * SOLID_PER_CELL]) -> impl Iterator<Item = &[f32]> {
    row.chunks_exact(2).take_while(|iv| !iv[0].is_nan())
}

/// Half the diagonal of the body's rectangle.
fn circumscribed_radius(p: &SurfaceParams) -> f64 {
    (p.body_length_m / 2.0).hypot(p.body_width_m / 2.0)
}

/// The cells the body can reach from the nodes of `trav`: their bounding
/// box grown by the circumscribed radius and a cell.
fn grid_bounds(trav: &TravMap, p: &SurfaceParams) -> ((i32, i32), (i32, i32)) {
    let margin = (circumscribed_radius(p) / trav.resolution()).ceil() as i32 + 2;
    let (mut x0, mut y0, mut x1, mut y1) = (i32::MAX, i32::MAX, i32::MIN, i32::MIN);
    for nd in trav.nodes() {
        x0 = x0.min(nd.ix);
        y0 = y0.min(nd.iy);
        x1 = x1.max(nd.ix);
        y1 = y1.max(nd.iy);
    }
    if x0 > x1 {
        return ((0, 0), (0, 0));
    }
    ((x0 - margin, y0 - margin), (x1 + margin, y1 + margin))
}

/// Cells of the table a lattice needs for the graph `trav` (for
/// [`SurfaceLattice::new`]'s `max_grid_cells`).
pub fn grid_cells_for(trav: &TravMap, p: &SurfaceParams) -> usize {
    let ((x0, y0), (x1, y1)) = grid_bounds(trav, p);
    (x1 - x0 + 1) as usize * (y1 - y0 + 1) as usize
}

/// Cells of the table for graphs kept within a square window of
/// `window_m` at `resolution_m`.
pub fn grid_cells_for_window(window_m: f64, resolution_m: f64, p: &SurfaceParams) -> usize {
    let margin = (circumscribed_radius(p) / resolution_m).ceil() as usize + 2;
    let side = (window_m / resolution_m).ceil() as usize + 2 + 2 * margin;
    side * side
}

/// The surface form of a primitive: its cell moves and body footprint.
fn surface_action(
    prim: &crate::mprim::MotionPrimitive,
    angles: u32,
    res: f64,
    p: &SurfaceParams,
) -> Option<SurfaceAction> {
    let cell = |x: f64, y: f64| {
        (
            ((x + res / 2.0) / res).floor() as i32,
            ((y + res / 2.0) / res).floor() as i32,
        )
    };
    let mut cells = vec![(0, 0)];
    let mut steps = Vec::new();
    for q in &prim.poses {
        let c = cell(q[0], q[1]);
        let last = cells[cells.len() - 1];
        if c != last {
            steps.push(direction(c.0 - last.0, c.1 - last.1)?);
            cells.push(c);
        }
    }
    // The body's rectangle at every pose, sampled at a quarter cell.
    let (hl, hw) = (p.body_length_m / 2.0, p.body_width_m / 2.0);
    let s = res / 4.0;
    let (nu, nv) = ((2.0 * hl / s).round() as i32, (2.0 * hw / s).round() as i32);
    let mut covered: Vec<(i32, i32)> = Vec::new();
    for q in &prim.poses {
        let (c, sn) = (q[2].cos(), q[2].sin());
        for i in 0..=nu {
            let u = -hl + 2.0 * hl * i as f64 / nu.max(1) as f64;
            for j in 0..=nv {
                let v = -hw + 2.0 * hw * j as f64 / nv.max(1) as f64;
                covered.push(cell(q[0] + u * c - v * sn, q[1] + u * sn + v * c));
            }
        }
    }
    covered.sort_unstable();
    covered.dedup();
    // Sorted by cell, as `covered` is.
    let footprint: Vec<(i32, i32, u16)> = covered
        .iter()
        .map(|&(ix, iy)| {
            let k = cells
                .iter()
                .enumerate()
                .min_by_key(|(_, cc)| (cc.0 - ix).pow(2) + (cc.1 - iy).pow(2))
                .map_or(0, |(k, _)| k);
            (ix, iy, k as u16)
        })
        .collect();
    let length_m = prim
        .poses
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    let bin = std::f64::consts::TAU / angles as f64;
    let d = (prim.end[2] - prim.start_angle as i32).rem_euclid(angles as i32);
    let turn_bins = d.min(angles as i32 - d);
    let first = prim.poses[0];
    let last = prim.poses[prim.poses.len() - 1];
    let backward = (last[0] * first[2].cos() + last[1] * first[2].sin()) < 0.0;
    Some(SurfaceAction {
        end_theta: prim.end[2].rem_euclid(angles as i32) as u32,
        steps,
        footprint,
        length_m,
        turn_rad: turn_bins as f64 * bin,
        backward,
        cost_mult: prim.cost_mult,
    })
}

impl Lattice for SurfaceLattice {
    fn max_successors(&self) -> usize {
        // And the any-heading goal.
        self.actions.iter().map(Vec::len).max().unwrap_or(0) + 1
    }

    fn state_count(&self) -> usize {
        // One more: the any-heading goal.
        self.trav.nodes().len() * self.angles as usize + 1
    }

    fn heuristic(&self, s: u32) -> u32 {
        if self.any_heading && s == self.virtual_goal() {
            return 0;
        }
        // Before the preparation is done nothing is reachable.
        self.heuristic
            .get(self.decode(s).0 as usize)
            .copied()
            .unwrap_or(INFINITE_COST)
    }

    fn work(&self) -> u64 {
        self.work.get()
    }

    fn successors(&self, s: u32, out: &mut Vec<(u32, u32)>) {
        out.clear();
        self.work.set(self.work.get() + 1);
        let (n, th) = self.decode(s);
        if self.prep != Prep::Ready || n as usize >= self.clear.len() {
            return;
        }
        if self.any_heading && n == self.goal.0 {
            out.push((self.virtual_goal(), 0));
        }
        let mut path = self.path.borrow_mut();
        for a in &self.actions[th as usize] {
            if let Some((end, cost)) = self.apply(n, a, &mut path) {
                out.push((self.state(end, a.end_theta), cost));
            }
        }
    }
}
