//! ARA* (Likhachev, Gordon, Thrun 2004): weighted A* with an inflation
//! `eps` that falls after every solution, reusing the search effort: the
//! states improved after they were expanded (INCONS) join OPEN again for
//! the next round. The first solution costs at most `eps` times the
//! optimum; the last, at `eps = 1`, is optimal.
//!
//! Determinism: keys are integers (`1000 g + eps_milli h`, ties to the
//! smaller `h`, then the smaller state number), so the same lattice gives
//! the same expansions and plan on any machine. Work comes in steps of a
//! fixed number of expansions ([`AraStar::step`]), never "as much as fits".
//!
//! Memory: every per-state array is taken at construction for the
//! lattice's state count; searching allocates nothing as long as the
//! lattice's `successors` does not.

use crate::INFINITE_COST;

/// A graph of densely numbered states for the search.
pub trait Lattice {
    /// States are `0..state_count()`.
    fn state_count(&self) -> usize;
    /// A lower bound on the cost from `s` to the goal (consistent for the
    /// last, `eps = 1`, solution to be optimal).
    fn heuristic(&self, s: u32) -> u32;
    /// `s`'s successors and the costs to reach them, into `out` (cleared
    /// first).
    fn successors(&self, s: u32, out: &mut Vec<(u32, u32)>);
    /// The most successors a state has (the search's buffer is sized
    /// for it).
    fn max_successors(&self) -> usize;
    /// The work the lattice has done generating successors so far (on
    /// the surface lattice, a path step or a footprint cell tested counts
    /// one); none when it does not count, and then an expansion is one
    /// unit of [`AraStar::step`].
    fn work(&self) -> u64 {
        0
    }
}

/// Lattice work ([`Lattice::work`]) that makes one unit of a step: about
/// an expansion's on open ground on the surface lattice (840 over the
/// planner's test worlds, 2,900 along walls).
pub const WORK_PER_UNIT: u64 = 1024;

/// How the inflation falls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AraParams {
    /// Inflation of the first search (at least 1).
    pub initial_eps: f64,
    /// Taken off after each solution, down to 1.
    pub eps_step: f64,
}

impl Default for AraParams {
    /// SBPL's: 3, falling by 0.2.
    fn default() -> Self {
        AraParams {
            initial_eps: 3.0,
            eps_step: 0.2,
        }
    }
}

/// What a step ended with.
///
/// A solution's `eps_milli` is the proven bound: the smaller of the
/// round's inflation and the cost over the least `g + h` left in OPEN.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// No query, or the last one is finished.
    Idle,
    /// The quantum ran out before the current round ended.
    Searching,
    /// A round ended with a solution of this cost, within `eps_milli /
    /// 1000` of the optimum; the next round has begun.
    Solution { eps_milli: u32, cost: u32 },
    /// The round at `eps = 1` ended: this cost is optimal.
    Optimal { cost: u32 },
    /// The goal cannot be reached from the start.
    NoPath,
}

const NONE: u32 = u32::MAX;
/// Fixed-point unit of `eps`.
const MILLI: u64 = 1000;
/// OPEN entries one unit of a round's end visits (about one expansion's
/// time).
const ENTRIES_PER_UNIT: usize = 64;

/// Where the end of a round is: the bound over OPEN, then the new keys,
/// then the heap order, each from entry `at`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Closing {
    Bound { at: usize, lower: u64, cost: u32 },
    Rekey { at: usize, proven: u32, cost: u32 },
    Heapify { at: usize, proven: u32, cost: u32 },
}

#[derive(Clone, Copy, Debug, Default)]
struct Entry {
    f: u64,
    h: u32,
    s: u32,
}

impl Entry {
    fn before(&self, o: &Entry) -> bool {
        (self.f, self.h, self.s) < (o.f, o.h, o.s)
    }
}

/// Figures of the current or last query.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AraStats {
    pub expansions: u64,
    /// Expansions when the first solution came (0 before).
    pub expansions_to_first: u64,
    pub rounds: u32,
    /// Inflation of the current round, thousandths.
    pub eps_milli: u32,
    /// Cost of the best solution so far.
    pub cost: u32,
}

/// The search and its per-state storage; see the module documentation.
pub struct AraStar {
    /// Query number each state's `g` and `parent` belong to.
    seen: Vec<u32>,
    g: Vec<u32>,
    parent: Vec<u32>,
    /// Round in which a state was last expanded (`round_id`).
    closed: Vec<u32>,
    /// Round in which a state was last put in INCONS.
    incons_mark: Vec<u32>,
    incons: Vec<u32>,
    heap: Vec<Entry>,
    /// Position in `heap`, `NONE` when out (valid for seen states).
    pos: Vec<u32>,
    succ: Vec<(u32, u32)>,
    query: u32,
    round_id: u32,
    goal: u32,
    start: u32,
    step_milli: u32,
    running: bool,
    /// Between rounds: the work on OPEN that a round's end needs, done in
    /// slices so that no step runs longer than its quantum.
    closing: Option<Closing>,
    /// What a step says once the query is over.
    finished: Progress,
    stats: AraStats,
}

impl AraStar {
    /// Storage for a lattice of `states` states whose states have at most
    /// `max_successors` successors.
    pub fn new(states: usize, max_successors: usize) -> Self {
        AraStar {
            seen: vec![0; states],
            g: vec![INFINITE_COST; states],
            parent: vec![NONE; states],
            closed: vec![0; states],
            incons_mark: vec![0; states],
            incons: Vec::with_capacity(states),
            heap: Vec::with_capacity(states),
            pos: vec![NONE; states],
            succ: Vec::with_capacity(max_successors),
            query: 0,
            round_id: 0,
            goal: 0,
            start: 0,
            step_milli: 200,
            running: false,
            closing: None,
            finished: Progress::Idle,
            stats: AraStats::default(),
        }
    }

    pub fn stats(&self) -> AraStats {
        self.stats
    }

    /// Begin a query; any earlier one is dropped. States outside the
    /// lattice give [`Progress::NoPath`] at the first step.
    pub fn start<L: Lattice>(&mut self, lat: &L, start: u32, goal: u32, p: AraParams) {
        for e in self.heap.drain(..) {
            self.pos[e.s as usize] = NONE;
        }
        self.incons.clear();
        self.query = self.query.wrapping_add(1);
        if self.query == 0 {
            // Wrapped: forget every mark once rather than risk a stale one.
            self.seen.fill(0);
            self.closed.fill(0);
            self.incons_mark.fill(0);
            self.query = 1;
        }
        self.round_id = self.round_id.wrapping_add(1).max(1);
        let eps = if p.initial_eps.is_finite() {
            p.initial_eps.max(1.0)
        } else {
            1.0
        };
        let step = if p.eps_step.is_finite() {
            p.eps_step.max(0.001)
        } else {
            1.0
        };
        self.stats = AraStats {
            eps_milli: (eps * MILLI as f64).round().min(1e9) as u32,
            ..AraStats::default()
        };
        self.step_milli = (step * MILLI as f64).round().min(1e9) as u32;
        self.start = start;
        self.goal = goal;
        let n = self.g.len();
        self.running = (start as usize) < n && (goal as usize) < n;
        self.closing = None;
        self.finished = Progress::NoPath;
        if self.running {
            self.touch(start);
            self.g[start as usize] = 0;
            self.push_or_update(lat, start);
        }
    }

    /// Up to `units` units of work, fewer if a round ends first: slices
    /// of [`ENTRIES_PER_UNIT`] OPEN entries at a round's end, and
    /// expansions, each one unit or, where the lattice counts its work,
    /// that work's units (the last one may overrun). An expansion where
    /// every pose is clear walks the primitives; one by a wall tests their
    /// footprints too, at up to ten times the cost.
    pub fn step<L: Lattice>(&mut self, lat: &L, units: u32) -> Progress {
        if !self.running {
            return self.finished;
        }
        let budget = units as u64 * WORK_PER_UNIT;
        let mut spent = 0u64;
        while spent < budget {
            let before = lat.work();
            if let Some(c) = self.closing {
                if let Some(p) = self.close(lat, c) {
                    return p;
                }
                spent += WORK_PER_UNIT;
                continue;
            }
            let goal_g = self.g_of(self.goal);
            let done = match self.heap.first() {
                None => true,
                Some(top) => goal_g != INFINITE_COST && goal_g as u64 * MILLI <= top.f,
            };
            if done {
                if let Some(p) = self.end_round() {
                    return p;
                }
                spent += WORK_PER_UNIT;
                continue;
            }
            self.expand(lat);
            spent += match lat.work() - before {
                0 => WORK_PER_UNIT,
                w => w,
            };
        }
        Progress::Searching
    }

    /// The states of the best solution, start first, into `out`.
    pub fn path(&self, out: &mut Vec<u32>) -> bool {
        out.clear();
        if self.g_of(self.goal) == INFINITE_COST {
            return false;
        }
        let mut s = self.goal;
        while s != NONE && out.len() <= self.g.len() {
            out.push(s);
            if s == self.start {
                out.reverse();
                return true;
            }
            s = self.parent[s as usize];
        }
        out.clear();
        false
    }

    fn g_of(&self, s: u32) -> u32 {
        let i = s as usize;
        if self.seen[i] == self.query {
            self.g[i]
        } else {
            INFINITE_COST
        }
    }

    fn touch(&mut self, s: u32) {
        let i = s as usize;
        if self.seen[i] != self.query {
            self.seen[i] = self.query;
            self.g[i] = INFINITE_COST;
            self.parent[i] = NONE;
            self.pos[i] = NONE;
        }
    }

    fn key<L: Lattice>(&self, lat: &L, s: u32) -> Entry {
        let h = lat.heuristic(s);
        let f = if h == INFINITE_COST {
            u64::MAX
        } else {
            self.g[s as usize] as u64 * MILLI + self.stats.eps_milli as u64 * h as u64
        };
        Entry { f, h, s }
    }

    fn expand<L: Lattice>(&mut self, lat: &L) {
        let top = self.pop();
        let s = top.s;
        self.closed[s as usize] = self.round_id;
        self.stats.expansions += 1;
        let gs = self.g[s as usize];
        let mut succ = std::mem::take(&mut self.succ);
        lat.successors(s, &mut succ);
        for &(t, c) in &succ {
            if t as usize >= self.g.len() {
                continue;
            }
            self.touch(t);
            let ng = gs.saturating_add(c);
            if ng >= self.g[t as usize] {
                continue;
            }
            self.g[t as usize] = ng;
            self.parent[t as usize] = s;
            if self.closed[t as usize] != self.round_id {
                self.push_or_update(lat, t);
            } else if self.incons_mark[t as usize] != self.round_id {
                self.incons_mark[t as usize] = self.round_id;
                self.incons.push(t);
            }
        }
        self.succ = succ;
    }

    /// The round is over: the optimum at `eps = 1` (or no path), otherwise
    /// OPEN takes INCONS and the bound over it begins.
    fn end_round(&mut self) -> Option<Progress> {
        let cost = self.g_of(self.goal);
        if cost == INFINITE_COST {
            self.running = false;
            return Some(Progress::NoPath);
        }
        self.stats.rounds += 1;
        self.stats.cost = cost;
        if self.stats.expansions_to_first == 0 {
            self.stats.expansions_to_first = self.stats.expansions.max(1);
        }
        if self.stats.eps_milli <= MILLI as u32 {
            return Some(self.optimal(cost));
        }
        // OPEN gets INCONS.
        self.round_id = self.round_id.wrapping_add(1).max(1);
        let incons = std::mem::take(&mut self.incons);
        for &t in &incons {
            if self.pos[t as usize] == NONE {
                self.pos[t as usize] = self.heap.len() as u32;
                self.heap.push(Entry { f: 0, h: 0, s: t });
            }
        }
        self.incons = incons;
        self.incons.clear();
        self.closing = Some(Closing::Bound {
            at: 0,
            lower: u64::MAX,
            cost,
        });
        None
    }

    fn optimal(&mut self, cost: u32) -> Progress {
        self.running = false;
        self.closing = None;
        self.finished = Progress::Idle;
        self.stats.eps_milli = MILLI as u32;
        Progress::Optimal { cost }
    }

    /// One slice of a round's end; the published solution once it is done.
    fn close<L: Lattice>(&mut self, lat: &L, c: Closing) -> Option<Progress> {
        let n = self.heap.len();
        match c {
            // A cheaper path would pass through a state of OPEN with g + h
            // below the cost: the smallest such sum bounds the optimum (the
            // ARA* paper's eps').
            Closing::Bound { at, lower, cost } => {
                let to = (at + ENTRIES_PER_UNIT).min(n);
                let mut lower = lower;
                for e in &self.heap[at..to] {
                    let h = lat.heuristic(e.s);
                    if h != INFINITE_COST {
                        lower = lower.min(self.g[e.s as usize] as u64 + h as u64);
                    }
                }
                if to < n {
                    self.closing = Some(Closing::Bound {
                        at: to,
                        lower,
                        cost,
                    });
                    return None;
                }
                let eps = self.stats.eps_milli;
                let bound = match lower {
                    u64::MAX => MILLI,
                    0 => u64::MAX,
                    l => (cost as u64 * MILLI).div_ceil(l),
                };
                let proven = (eps as u64).min(bound).max(MILLI) as u32;
                if lower >= cost as u64 {
                    return Some(self.optimal(cost));
                }
                // The next round: eps lowered by the step, or to the bound
                // if that is lower already.
                let next = eps.saturating_sub(self.step_milli).min(proven);
                self.stats.eps_milli = next.max(MILLI as u32);
                self.closing = Some(Closing::Rekey {
                    at: 0,
                    proven,
                    cost,
                });
                None
            }
            Closing::Rekey { at, proven, cost } => {
                let to = (at + ENTRIES_PER_UNIT).min(n);
                for i in at..to {
                    let s = self.heap[i].s;
                    self.heap[i] = self.key(lat, s);
                }
                self.closing = Some(if to < n {
                    Closing::Rekey {
                        at: to,
                        proven,
                        cost,
                    }
                } else {
                    Closing::Heapify {
                        at: n / 2,
                        proven,
                        cost,
                    }
                });
                None
            }
            // Sift down from the last parent to the root, a slice at a
            // time: `at` parents are left.
            Closing::Heapify { at, proven, cost } => {
                let from = at.saturating_sub(ENTRIES_PER_UNIT);
                for i in (from..at).rev() {
                    self.sift_down(i);
                }
                if from > 0 {
                    self.closing = Some(Closing::Heapify {
                        at: from,
                        proven,
                        cost,
                    });
                    return None;
                }
                self.closing = None;
                Some(Progress::Solution {
                    eps_milli: proven,
                    cost,
                })
            }
        }
    }

    fn push_or_update<L: Lattice>(&mut self, lat: &L, s: u32) {
        let e = self.key(lat, s);
        if e.f == u64::MAX {
            return; // the goal is out of its reach
        }
        let p = self.pos[s as usize];
        if p == NONE {
            self.heap.push(e);
            let i = self.heap.len() - 1;
            self.pos[s as usize] = i as u32;
            self.sift_up(i);
        } else {
            // Keys only fall (g fell, h and eps are fixed within a round).
            self.heap[p as usize] = e;
            self.sift_up(p as usize);
        }
    }

    fn pop(&mut self) -> Entry {
        let top = self.heap[0];
        self.pos[top.s as usize] = NONE;
        let last = self.heap.len() - 1;
        if last > 0 {
            self.heap[0] = self.heap[last];
            self.pos[self.heap[0].s as usize] = 0;
        }
        self.heap.truncate(last);
        if last > 0 {
            self.sift_down(0);
        }
        top
    }

    fn sift_up(&mut self, mut i: usize) {
        let e = self.heap[i];
        while i > 0 {
            let p = (i - 1) / 2;
            if !e.before(&self.heap[p]) {
                break;
            }
            self.heap[i] = self.heap[p];
            self.pos[self.heap[i].s as usize] = i as u32;
            i = p;
        }
        self.heap[i] = e;
        self.pos[e.s as usize] = i as u32;
    }

    fn sift_down(&mut self, mut i: usize) {
        let n = self.heap.len();
        let e = self.heap[i];
        loop {
            let l = 2 * i + 1;
            if l >= n {
                break;
            }
            let r = l + 1;
            let c = if r < n && self.heap[r].before(&self.heap[l]) {
                r
            } else {
                l
            };
            if !self.heap[c].before(&e) {
                break;
            }
            self.heap[i] = self.heap[c];
            self.pos[self.heap[i].s as usize] = i as u32;
            i = c;
        }
        self.heap[i] = e;
        self.pos[e.s as usize] = i as u32;
    }
}
