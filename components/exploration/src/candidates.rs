//! Exploration candidates: the graph's frontier and explorable patches,
//! each scored by its distance from the rover, the unexplored cells around
//! it and, when a target is given, its distance from the target (the
//! paper's three criteria). The scan runs over the graph in slices and
//! keeps the best few; ties go to the lower node index, so the same graph
//! gives the same choice.

use speleo_traversability::{TravClass, TravMap, Window};

use crate::coverage::CoverageMap;

/// Cells just inside the window's margin whose drivable patches are
/// candidates.
const BORDER_BAND: i32 = 2;

/// Candidates kept, best first: the planner tries them in turn.
pub const MAX_CANDIDATES: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CandidateParams {
    /// Candidates nearer the rover than this give too little progress, m.
    pub min_distance_m: f64,
    /// Cells within this radius count toward "unexplored nearby", m.
    pub unexplored_radius_m: f64,
    /// Score: metres of distance from the rover ...
    pub weight_distance: f64,
    /// ... less this per m^2 of unexplored ground nearby ...
    pub weight_unexplored: f64,
    /// ... plus this per metre from the target, when there is one.
    pub weight_target: f64,
    /// Patches this near the border of the growth window are not
    /// candidates (the graph stops there, the map does not), m.
    pub border_margin_m: f64,
    /// Patches this near a goal that failed are not tried again, m.
    pub rejected_radius_m: f64,
    /// Patches with an obstacle patch this near are not candidates (the
    /// rover's body would not fit there), m.
    pub clearance_m: f64,
    /// ... unless nothing else is left: then a second pass takes patches
    /// with this much room. The waist of a squeeze, where the body just
    /// fits, is never a candidate at `clearance_m`, and the cave beyond
    /// it would never be explored (the simulated tube's squeeze ended
    /// exploration with a third of its floor unseen); taking such tight
    /// goals from the start sends the rover along every wall.
    pub tight_clearance_m: f64,
    /// When neither pass finds anything, a third takes crests: border
    /// patches at least this much over the ground the rover stands on,
    /// m. The LiDAR, 0.6 m up, grazes such ground at best and never sees
    /// past it: 1.7 m short of a garage ramp's top, the next level's
    /// edge lay 0.43 m over the rover's ground, too near and covered, and
    /// the rover turned back down without once looking over it.
    pub crest_rise_m: f64,
    /// Crests are looked for this far from the rover at most, and at
    /// least `crest_min_distance_m`, m: the pass is for the ground just
    /// ahead that one short drive shows.
    pub crest_reach_m: f64,
    pub crest_min_distance_m: f64,
    /// A goal with a rock rising more than this under the body is not
    /// driven to, m: the planner's `SurfaceLattice::rock_m`, the highest
    /// ground under the body's inscribed circle over the plane of the
    /// ground round it where the wheels stand. The rover stops at a goal
    /// and turns there, and turning on the spot over a rock it straddles
    /// wedges it: in the lava tube two goals over rocks the map held at
    /// 0.066 and 0.083 m over the goal node's own support plane (truly
    /// 0.15-0.19 m over the floor round them, 0.26 m across) stuck the
    /// rover, the second for good, and 26 other goals of the same run
    /// had no bump over 0.04 m; over the ring's plane such boulders read
    /// 0.12 m. 0: off (the default for now: it changes the missions'
    /// courses, and has been measured on few).
    pub max_rock_m: f64,
}

impl Default for CandidateParams {
    fn default() -> Self {
        CandidateParams {
            min_distance_m: 2.0,
            unexplored_radius_m: 1.0,
            weight_distance: 1.0,
            weight_unexplored: 2.0,
            weight_target: 0.0,
            border_margin_m: 1.0,
            rejected_radius_m: 1.5,
            clearance_m: 0.45,
            tight_clearance_m: 0.15,
            crest_rise_m: 0.25,
            crest_reach_m: 4.0,
            crest_min_distance_m: 0.5,
            max_rock_m: 0.0,
        }
    }
}

/// Why the scanned nodes were not candidates, and how far the graph
/// reached: the log of a scan that found nothing (at the lava tube's far
/// end the graph ended two metres ahead of the rover, and why was not
/// known).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScanCensus {
    pub scanned: u32,
    /// Neither a frontier nor an explorable patch, nor at the border.
    pub inner: u32,
    /// Within `border_margin_m` of the window's edge.
    pub beyond_margin: u32,
    pub too_near: u32,
    pub covered: u32,
    pub rejected: u32,
    pub cramped: u32,
    /// In the crest pass: scanned patches that are no crest (not at the
    /// border, not `crest_rise_m` over the rover, out of reach, or stood
    /// as high near already), and of them, the first reason each failed:
    /// on the garage's roof ramp the pass refused 204 patches 3.5 m short
    /// of the top, and why was not known.
    pub no_crest: u32,
    pub crest_not_border: u32,
    pub crest_low: u32,
    pub crest_out_of_reach: u32,
    pub crest_stood: u32,
    /// The scanned node farthest from the rover, and its distance, m.
    pub farthest: [f64; 3],
    pub farthest_m: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    pub node: u32,
    pub position: [f64; 3],
    /// Lower is better.
    pub score: f64,
    /// Unexplored area nearby, m^2.
    pub unexplored_m2: f64,
}

/// The passes of a scan, in order: each runs only when the ones before
/// found nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// Patches with `clearance_m` of room.
    Roomy,
    /// Patches with `tight_clearance_m` of room (a squeeze's waist).
    Tight,
    /// Crests just over the rover (`crest_rise_m`), near or covered.
    Crest,
}

/// A scan of the graph for candidates, in slices.
#[derive(Clone, Debug)]
pub struct CandidateScan {
    p: CandidateParams,
    next: usize,
    rover: [f64; 2],
    target: Option<[f64; 2]>,
    window: Option<Window>,
    pass: Pass,
    /// The ground under the rover (the graph's first node), for crests.
    rover_ground_z: Option<f64>,
    best: heapless::Vec<Candidate, MAX_CANDIDATES>,
    census: ScanCensus,
}

impl CandidateScan {
    pub fn new(p: CandidateParams) -> Self {
        CandidateScan {
            p,
            next: 0,
            rover: [0.0; 2],
            target: None,
            window: None,
            pass: Pass::Roomy,
            rover_ground_z: None,
            best: heapless::Vec::new(),
            census: ScanCensus::default(),
        }
    }

    pub fn params(&self) -> &CandidateParams {
        &self.p
    }

    /// Start a scan for a rover at `rover` on a graph grown within `window`.
    pub fn begin(&mut self, rover: [f64; 2], target: Option<[f64; 2]>, window: Option<Window>) {
        self.next = 0;
        self.rover = rover;
        self.target = target;
        self.window = window;
        self.pass = Pass::Roomy;
        self.best.clear();
        self.census = ScanCensus::default();
    }

    /// Scan again in the next pass (after one that found nothing): tight
    /// places, then crests; false when this pass was the last.
    pub fn next_pass(&mut self) -> bool {
        self.pass = match self.pass {
            Pass::Roomy => Pass::Tight,
            Pass::Tight => Pass::Crest,
            Pass::Crest => return false,
        };
        self.next = 0;
        self.best.clear();
        // The crest pass counts only its own misses: why the others found
        // nothing stays in the census.
        let before = self.census;
        self.census = ScanCensus::default();
        if self.pass == Pass::Crest {
            self.census.too_near = before.too_near;
            self.census.covered = before.covered;
        }
        true
    }

    /// The pass under way.
    pub fn pass(&self) -> Pass {
        self.pass
    }

    /// Score more nodes until `work` units are spent (a node looked at,
    /// and a cell looked up around a candidate, count one each); true
    /// when the whole graph is scanned. A slice of nodes took from 15 us
    /// to 1.7 ms: most nodes are passed over at a glance, and a frontier's
    /// are each scored over a hundred cells.
    pub fn step(
        &mut self,
        trav: &TravMap,
        coverage: &CoverageMap,
        rejected: &[[f64; 2]],
        work: u64,
    ) -> bool {
        let all = trav.nodes().len();
        if self.next == 0 {
            self.rover_ground_z = trav.node(0).map(|n| n.ground_z as f64);
        }
        let mut census = self.census;
        let mut spent = 0u64;
        while self.next < all && spent < work.max(1) {
            let i = self.next as u32;
            self.next += 1;
            spent += 1;
            if let Some(c) = self.score(trav, coverage, rejected, i, &mut census, &mut spent) {
                self.keep(c);
            }
        }
        self.census = census;
        self.next == all
    }

    /// Best first.
    pub fn best(&self) -> &[Candidate] {
        &self.best
    }

    /// Why this pass's nodes were not candidates.
    pub fn census(&self) -> &ScanCensus {
        &self.census
    }

    /// Keep `c` among the best unless a better one lies within the
    /// rejection radius; worse ones within it go. Neighbouring patches of
    /// one frontier would otherwise fill the list, and when that goal
    /// cannot be reached, every one of them would be planned to in turn
    /// (in the garage, eight goals along one wall each took a search to
    /// its expansion limit).
    fn keep(&mut self, c: Candidate) {
        let r2 = self.p.rejected_radius_m.powi(2);
        let near = |b: &Candidate| {
            (b.position[0] - c.position[0]).powi(2) + (b.position[1] - c.position[1]).powi(2) <= r2
        };
        if self.best.iter().any(|b| b.score <= c.score && near(b)) {
            return;
        }
        self.best.retain(|b| !near(b));
        let at = self
            .best
            .iter()
            .position(|b| c.score < b.score)
            .unwrap_or(self.best.len());
        if at < MAX_CANDIDATES {
            if self.best.is_full() {
                self.best.pop();
            }
            let _ = self.best.insert(at, c);
        }
    }

    fn score(
        &self,
        trav: &TravMap,
        coverage: &CoverageMap,
        rejected: &[[f64; 2]],
        i: u32,
        census: &mut ScanCensus,
        work: &mut u64,
    ) -> Option<Candidate> {
        let n = trav.node(i)?;
        let res = trav.resolution();
        census.scanned += 1;
        let p = trav.position(n);
        let d = (p[0] - self.rover[0]).hypot(p[1] - self.rover[1]);
        if d > census.farthest_m {
            census.farthest_m = d;
            census.farthest = p;
        }
        // Within the margin of the window's border the graph stops but the
        // map goes on: no frontier there is real. Just inside the margin,
        // any drivable patch is a candidate: the map beyond the window is
        // unexplored as far as the rover knows (a long tube is seen
        // farther than the window reaches).
        let at_border = match self.window {
            Some(w) => {
                let m = (self.p.border_margin_m / res).ceil() as i32;
                let inside = |lo: i32, v: i32, hi: i32| v - lo >= m && hi - v >= m;
                if !inside(w.min.0, n.ix, w.max.0) || !inside(w.min.1, n.iy, w.max.1) {
                    census.beyond_margin += 1;
                    return None;
                }
                let edge =
                    |lo: i32, v: i32, hi: i32| v - lo < m + BORDER_BAND || hi - v < m + BORDER_BAND;
                edge(w.min.0, n.ix, w.max.0) || edge(w.min.1, n.iy, w.max.1)
            }
            None => false,
        };
        // Where a full graph stopped (the node limit, not the map), as at
        // the window's border: at the garage's roof ramp the graph filled
        // up over the levels below before it reached the roof's frontier,
        // and no candidate was left.
        let at_border = at_border || n.cut;
        let border_class = matches!(n.class, TravClass::Frontier | TravClass::Explorable);
        // Ground the graph reaches on another level than the rover drove
        // there: the upper part of a ramp driven under, whose far end the
        // rings saw from below only as scattered stripes that close the
        // graph without a frontier. Going up is the only way to see on.
        let other_level = n.class.is_drivable() && coverage.level_apart(p[0], p[1], p[2]);
        if !(border_class || other_level || (at_border && n.class.is_drivable())) {
            census.inner += 1;
            return None;
        }
        if self.pass == Pass::Crest {
            // Near and covered or not: only ground over the rover that it
            // has not yet stood as high as near here.
            let rise = self.rover_ground_z.map_or(f64::NEG_INFINITY, |g| p[2] - g);
            let reach = self.p.crest_min_distance_m..=self.p.crest_reach_m;
            let miss = if !border_class {
                Some(&mut census.crest_not_border)
            } else if rise < self.p.crest_rise_m {
                Some(&mut census.crest_low)
            } else if !reach.contains(&d) {
                Some(&mut census.crest_out_of_reach)
            } else if coverage.stood_as_high(p[0], p[1], p[2]) {
                Some(&mut census.crest_stood)
            } else {
                None
            };
            if let Some(reason) = miss {
                *reason += 1;
                census.no_crest += 1;
                return None;
            }
        } else {
            if d < self.p.min_distance_m {
                census.too_near += 1;
                return None;
            }
            if coverage.covered(p[0], p[1], p[2]) {
                census.covered += 1;
                return None;
            }
        }
        let r2 = self.p.rejected_radius_m.powi(2);
        if rejected
            .iter()
            .any(|q| (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) <= r2)
        {
            census.rejected += 1;
            return None;
        }
        let clearance = match self.pass {
            Pass::Tight => self.p.tight_clearance_m,
            Pass::Roomy | Pass::Crest => self.p.clearance_m,
        };
        if obstacle_near(trav, n.ix, n.iy, n.ground_z, clearance, work) {
            census.cramped += 1;
            return None;
        }
        let unexplored_m2 = unexplored_near(trav, n.ix, n.iy, self.p.unexplored_radius_m, work);
        let mut score = self.p.weight_distance * d - self.p.weight_unexplored * unexplored_m2;
        if let Some(t) = self.target {
            score += self.p.weight_target * (p[0] - t[0]).hypot(p[1] - t[1]);
        }
        Some(Candidate {
            node: i,
            position: p,
            score,
            unexplored_m2,
        })
    }
}

/// Whether an obstacle patch near height `z` lies within `radius_m`; the
/// cells looked up are added to `work`.
fn obstacle_near(trav: &TravMap, ix: i32, iy: i32, z: f32, radius_m: f64, work: &mut u64) -> bool {
    let r = (radius_m / trav.resolution()).round() as i32;
    for dy in -r..=r {
        for dx in -r..=r {
            if dx * dx + dy * dy > r * r {
                continue;
            }
            *work += 1;
            let hit = trav.nodes_in_cell(ix + dx, iy + dy).any(|j| {
                trav.node(j)
                    .is_some_and(|m| m.class == TravClass::Obstacle && (m.ground_z - z).abs() < 0.5)
            });
            if hit {
                return true;
            }
        }
    }
    false
}

/// Area within `radius_m` of cell (ix, iy) where the graph has no patch,
/// m^2, sampled on every other cell (the graph's gaps are unobserved
/// ground, walls and what lies behind them); the cells looked up are
/// added to `work`.
fn unexplored_near(trav: &TravMap, ix: i32, iy: i32, radius_m: f64, work: &mut u64) -> f64 {
    let res = trav.resolution();
    let r = (radius_m / res).round() as i32;
    let mut empty = 0u32;
    for dy in (-r..=r).step_by(2) {
        for dx in (-r..=r).step_by(2) {
            if dx * dx + dy * dy > r * r {
                continue;
            }
            *work += 1;
            if trav.nodes_in_cell(ix + dx, iy + dy).next().is_none() {
                empty += 1;
            }
        }
    }
    // Each sample stands for 2 x 2 cells.
    empty as f64 * 4.0 * res * res
}
