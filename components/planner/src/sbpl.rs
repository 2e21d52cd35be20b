//! SBPL's `EnvironmentNAVXYTHETALAT` for a point robot: the same `.cfg`
//! files, discretisation and action costs, so that our search can be
//! checked against SBPL's optimal costs.
//!
//! - Cells: `x = (int)(metres / cellsize)` (one lower for negatives), the
//!   grid read row by row (`y`), each row `x = 0..width`.
//! - An action from `(x, y, theta)` is every primitive starting at
//!   `theta`; it ends at `(x + dx, y + dy, end_theta mod angles)`.
//! - Its base cost is `ceil(1000 * max(linear_time, angular_time))` times
//!   `additionalactioncostmult`, with the linear time the length of the
//!   intermediate poses over `nominalvel` and the angular time the angle
//!   between the start and end bins over the 45-degree turning rate.
//! - It is refused when the end cell or a cell holding an intermediate pose
//!   (from the start cell's centre) is outside the grid or costs at least
//!   `cost_inscribed_thresh`, or the start or end cell at least
//!   `obsthresh`; otherwise it costs the base cost times one plus the
//!   largest cell cost among those cells, the start and the end.

use thiserror::Error;

use crate::mprim::{MprimError, MprimFile, Tokens};
use crate::{Lattice, INFINITE_COST};

#[derive(Debug, Error)]
pub enum SbplError {
    #[error("environment: {0}")]
    Cfg(MprimError),
    #[error("the primitives are for {found} m cells, the environment has {expected} m")]
    Resolution { expected: f64, found: f64 },
    #[error("the primitives have {found} headings, the environment {expected}")]
    Angles { expected: u32, found: u32 },
    #[error("{cells} cells x {angles} headings is more states than the planner numbers")]
    TooManyStates { cells: usize, angles: u32 },
    #[error("the {which} pose ({x}, {y}) is outside the grid or in an obstacle")]
    BadEndpoint { which: &'static str, x: i32, y: i32 },
}

/// An environment as its `.cfg` file gives it.
#[derive(Clone, Debug, PartialEq)]
pub struct SbplEnv {
    pub width: usize,
    pub height: usize,
    pub angles: u32,
    pub obsthresh: u8,
    pub cost_inscribed_thresh: u8,
    pub cost_possibly_circumscribed_thresh: i32,
    pub cellsize_m: f64,
    pub nominalvel_mps: f64,
    pub time_to_turn_45_s: f64,
    /// Start and goal: metres and radians.
    pub start: [f64; 3],
    pub goal: [f64; 3],
    /// Cell costs, `x + y * width`.
    pub grid: Vec<u8>,
}

/// Largest grid accepted (cells).
const MAX_CELLS: usize = 1 << 26;
/// Largest cell offset an action may reach (beyond every grid).
const MAX_OFFSET: i32 = 1 << 24;

/// Parse an environment `.cfg` file.
pub fn parse_env(text: &str) -> Result<SbplEnv, SbplError> {
    parse_env_tokens(text).map_err(SbplError::Cfg)
}

fn parse_env_tokens(text: &str) -> Result<SbplEnv, MprimError> {
    let mut t = Tokens::new(text);
    t.key("discretization(cells):")?;
    let width = t.ranged("width", 1, 1 << 20)? as usize;
    let height = t.ranged("height", 1, 1 << 20)? as usize;
    if width * height > MAX_CELLS {
        return Err(t.err(format!("{width} x {height} cells is more than {MAX_CELLS}")));
    }
    let angles = if t.optional_key("NumThetaDirs:") {
        t.ranged("NumThetaDirs", 1, 1024)? as u32
    } else {
        16
    };
    t.key("obsthresh:")?;
    let obsthresh = t.ranged("obsthresh", 0, 255)? as u8;
    t.key("cost_inscribed_thresh:")?;
    let cost_inscribed_thresh = t.ranged("cost_inscribed_thresh", 0, 255)? as u8;
    t.key("cost_possibly_circumscribed_thresh:")?;
    let cost_possibly_circumscribed_thresh =
        t.ranged("cost_possibly_circumscribed_thresh", -1, 255)? as i32;
    let positive = |t: &mut Tokens, key: &str, what: &str| -> Result<f64, MprimError> {
        t.key(key)?;
        let v = t.float(what)?;
        if v <= 0.0 {
            return Err(t.err(format!("{what} must be positive")));
        }
        Ok(v)
    };
    let cellsize_m = positive(&mut t, "cellsize(meters):", "cellsize")?;
    let nominalvel_mps = positive(&mut t, "nominalvel(mpersecs):", "nominalvel")?;
    let time_to_turn_45_s = positive(
        &mut t,
        "timetoturn45degsinplace(secs):",
        "timetoturn45degsinplace",
    )?;
    let pose = |t: &mut Tokens, key: &str| -> Result<[f64; 3], MprimError> {
        t.key(key)?;
        Ok([t.float("x")?, t.float("y")?, t.float("theta")?])
    };
    let start = pose(&mut t, "start(meters,rads):")?;
    let goal = pose(&mut t, "end(meters,rads):")?;
    t.key("environment:")?;
    let mut grid = vec![0u8; width * height];
    for y in 0..height {
        for x in 0..width {
            grid[x + y * width] = t.ranged("cell cost", 0, 255)? as u8;
        }
    }
    if !t.at_end() {
        let extra = t.next("")?;
        return Err(t.err(format!("`{extra}` after the {width} x {height} cells")));
    }
    Ok(SbplEnv {
        width,
        height,
        angles,
        obsthresh,
        cost_inscribed_thresh,
        cost_possibly_circumscribed_thresh,
        cellsize_m,
        nominalvel_mps,
        time_to_turn_45_s,
        start,
        goal,
        grid,
    })
}

/// SBPL's metres to cell: truncation, one lower for negatives.
pub fn cont_to_disc(v: f64, cellsize: f64) -> i32 {
    let q = v / cellsize;
    if v >= 0.0 {
        q as i32
    } else {
        q as i32 - 1
    }
}

/// SBPL's angle to heading bin (bins centred on multiples of 2 pi / n).
pub fn angle_to_bin(theta: f64, angles: u32) -> u32 {
    let tau = std::f64::consts::TAU;
    let bin = tau / angles as f64;
    let mut a = (theta + bin / 2.0) % tau;
    if a < 0.0 {
        a += tau;
    }
    ((a / tau * angles as f64) as u32).min(angles - 1)
}

/// One action from a heading: its end offset and heading, base cost, and
/// the cells (relative to the start cell) its intermediate poses visit.
#[derive(Clone, Debug, PartialEq)]
pub struct Action {
    pub dx: i32,
    pub dy: i32,
    pub end_theta: u32,
    pub base_cost: u32,
    pub cells: Vec<(i32, i32)>,
    /// Length of the intermediate poses, m.
    pub length_m: f64,
    /// The primitive it comes from (index in the file).
    pub primitive: usize,
}

/// The lattice: states `(x, y, theta)` numbered `(y * width + x) * angles
/// + theta`.
pub struct SbplLattice {
    pub env: SbplEnv,
    /// Actions by start heading.
    pub actions: Vec<Vec<Action>>,
    pub start: (i32, i32, u32),
    pub goal: (i32, i32, u32),
    heuristic: Vec<u32>,
}

/// SBPL's `normalizeAngle` (to `[0, 2 pi]`), step for step: costs are
/// rounded up, so the last bit matters.
fn normalize_angle(a: f64) -> f64 {
    let tau = 2.0 * std::f64::consts::PI;
    let mut r = a;
    if r.abs() > tau {
        r -= ((r / tau) as i64) as f64 * tau;
    }
    if r < 0.0 {
        r += tau;
    }
    r
}

/// SBPL's `computeMinUnsignedAngleDiff`.
fn min_angle_diff(a: f64, b: f64) -> f64 {
    let d = (normalize_angle(a) - normalize_angle(b)).abs();
    if d > std::f64::consts::PI {
        2.0 * std::f64::consts::PI - d
    } else {
        d
    }
}

impl SbplLattice {
    /// Combine an environment and primitives as SBPL does.
    pub fn new(env: SbplEnv, prims: &MprimFile) -> Result<Self, SbplError> {
        if (prims.resolution_m - env.cellsize_m).abs() > 1e-3 * env.cellsize_m {
            return Err(SbplError::Resolution {
                expected: env.cellsize_m,
                found: prims.resolution_m,
            });
        }
        if prims.angles != env.angles {
            return Err(SbplError::Angles {
                expected: env.angles,
                found: prims.angles,
            });
        }
        let n = env.angles;
        // SBPL's DiscTheta2Cont: the bin times the bin size, unnormalised.
        let bin = |b: i64| b as f64 * (2.0 * std::f64::consts::PI / n as f64);
        let cs = env.cellsize_m;
        let half = cs / 2.0;
        let mut actions = vec![Vec::new(); n as usize];
        for (i, p) in prims.primitives.iter().enumerate() {
            let mut cells: Vec<(i32, i32)> = Vec::new();
            for q in &p.poses {
                // Clamped far beyond any grid, so offsets never overflow.
                let c = (
                    cont_to_disc(q[0] + half, cs).clamp(-MAX_OFFSET, MAX_OFFSET),
                    cont_to_disc(q[1] + half, cs).clamp(-MAX_OFFSET, MAX_OFFSET),
                );
                if cells.last() != Some(&c) {
                    cells.push(c);
                }
            }
            let length_m: f64 = p
                .poses
                .windows(2)
                .map(|w| {
                    // sqrt, not hypot: SBPL's rounding.
                    let (dx, dy) = (w[1][0] - w[0][0], w[1][1] - w[0][1]);
                    (dx * dx + dy * dy).sqrt()
                })
                .sum();
            let linear = length_m / env.nominalvel_mps;
            let turn = min_angle_diff(bin(p.end[2] as i64), bin(p.start_angle as i64));
            let angular = turn / (std::f64::consts::FRAC_PI_4 / env.time_to_turn_45_s);
            // Saturating: absurd poses give an absurd cost, never a wrap.
            let base =
                ((1000.0 * linear.max(angular)).ceil() as u64).saturating_mul(p.cost_mult as u64);
            actions[p.start_angle as usize].push(Action {
                dx: p.end[0],
                dy: p.end[1],
                end_theta: p.end[2].rem_euclid(n as i32) as u32,
                base_cost: base.min(INFINITE_COST as u64 / 256) as u32,
                cells,
                length_m,
                primitive: i,
            });
        }
        let to_cell = |p: [f64; 3]| {
            (
                cont_to_disc(p[0], cs),
                cont_to_disc(p[1], cs),
                angle_to_bin(p[2], n),
            )
        };
        let (start, goal) = (to_cell(env.start), to_cell(env.goal));
        let mut l = SbplLattice {
            heuristic: Vec::new(),
            env,
            actions,
            start,
            goal,
        };
        for (which, (x, y, _)) in [("start", start), ("goal", goal)] {
            if !l.valid(x, y) {
                return Err(SbplError::BadEndpoint { which, x, y });
            }
        }
        l.heuristic = crate::heuristic::cost_to_go(&l);
        Ok(l)
    }

    pub fn state(&self, x: i32, y: i32, theta: u32) -> u32 {
        ((y as usize * self.env.width + x as usize) * self.env.angles as usize + theta as usize)
            as u32
    }

    pub fn decode(&self, s: u32) -> (i32, i32, u32) {
        let a = self.env.angles as usize;
        let cell = s as usize / a;
        (
            (cell % self.env.width) as i32,
            (cell / self.env.width) as i32,
            (s as usize % a) as u32,
        )
    }

    pub fn start_state(&self) -> u32 {
        self.state(self.start.0, self.start.1, self.start.2)
    }

    pub fn goal_state(&self) -> u32 {
        self.state(self.goal.0, self.goal.1, self.goal.2)
    }

    fn inside(&self, x: i32, y: i32) -> bool {
        x >= 0 && y >= 0 && (x as usize) < self.env.width && (y as usize) < self.env.height
    }

    fn cost_at(&self, x: i32, y: i32) -> u8 {
        self.env.grid[x as usize + y as usize * self.env.width]
    }

    /// SBPL's `IsValidCell`.
    fn valid(&self, x: i32, y: i32) -> bool {
        self.inside(x, y) && self.cost_at(x, y) < self.env.obsthresh
    }

    /// SBPL's `GetActionCost` for a point robot.
    pub fn action_cost(&self, x: i32, y: i32, a: &Action) -> u32 {
        let (ex, ey) = (x + a.dx, y + a.dy);
        if !self.valid(x, y) || !self.valid(ex, ey) {
            return INFINITE_COST;
        }
        let inscribed = self.env.cost_inscribed_thresh;
        let end_cost = self.cost_at(ex, ey);
        if end_cost >= inscribed {
            return INFINITE_COST;
        }
        let mut max = 0u8;
        for &(cx, cy) in &a.cells {
            let (cx, cy) = (cx + x, cy + y);
            if !self.inside(cx, cy) {
                return INFINITE_COST;
            }
            max = max.max(self.cost_at(cx, cy));
            if max >= inscribed {
                return INFINITE_COST;
            }
        }
        let max = max.max(self.cost_at(x, y)).max(end_cost);
        a.base_cost * (max as u32 + 1)
    }

    /// Every action of every heading.
    pub fn all_actions(&self) -> impl Iterator<Item = &Action> {
        self.actions.iter().flatten()
    }

    /// Length of the path through these states, m (the primitives'
    /// intermediate poses).
    pub fn path_length_m(&self, states: &[u32]) -> f64 {
        states
            .windows(2)
            .filter_map(|w| {
                let (x, y, th) = self.decode(w[0]);
                let to = self.decode(w[1]);
                self.actions[th as usize]
                    .iter()
                    .filter(|a| (x + a.dx, y + a.dy, a.end_theta) == to)
                    .min_by_key(|a| self.action_cost(x, y, a))
                    .map(|a| a.length_m)
            })
            .sum()
    }

    pub fn cell_count(&self) -> usize {
        self.env.width * self.env.height
    }

    pub fn cell_of(&self, s: u32) -> usize {
        s as usize / self.env.angles as usize
    }

    pub fn cell_xy(&self, cell: usize) -> (i32, i32) {
        (
            (cell % self.env.width) as i32,
            (cell / self.env.width) as i32,
        )
    }

    pub fn cell_index(&self, x: i32, y: i32) -> Option<usize> {
        self.inside(x, y)
            .then(|| x as usize + y as usize * self.env.width)
    }
}

impl Lattice for SbplLattice {
    fn max_successors(&self) -> usize {
        self.actions.iter().map(Vec::len).max().unwrap_or(0)
    }

    fn state_count(&self) -> usize {
        self.cell_count() * self.env.angles as usize
    }

    fn heuristic(&self, s: u32) -> u32 {
        self.heuristic[self.cell_of(s)]
    }

    fn successors(&self, s: u32, out: &mut Vec<(u32, u32)>) {
        out.clear();
        let (x, y, th) = self.decode(s);
        for a in &self.actions[th as usize] {
            let c = self.action_cost(x, y, a);
            if c != INFINITE_COST {
                out.push((self.state(x + a.dx, y + a.dy, a.end_theta), c));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discretisation_follows_sbpl() {
        assert_eq!(cont_to_disc(0.35, 0.025), 13, "0.35 / 0.025 floors to 13");
        assert_eq!(cont_to_disc(0.11, 0.025), 4);
        assert_eq!(cont_to_disc(-0.01, 0.025), -1);
        assert_eq!(angle_to_bin(0.0, 16), 0);
        assert_eq!(angle_to_bin(-0.1, 16), 0);
        assert_eq!(angle_to_bin(std::f64::consts::FRAC_PI_2, 16), 4);
        assert_eq!(angle_to_bin(-std::f64::consts::FRAC_PI_2, 16), 12);
    }

    #[test]
    fn malformed_environments_name_the_line() {
        let good = "discretization(cells): 2 2\nobsthresh: 1\ncost_inscribed_thresh: 1\n\
            cost_possibly_circumscribed_thresh: 0\ncellsize(meters): 0.1\nnominalvel(mpersecs): 1.0\n\
            timetoturn45degsinplace(secs): 2.0\nstart(meters,rads): 0.0 0.0 0\n\
            end(meters,rads): 0.1 0.1 0\nenvironment:\n0 0\n0 0\n";
        let env = parse_env(good).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((env.width, env.height, env.angles), (2, 2, 16));
        for (bad, why) in [
            (
                good.replace("0 0\n0 0\n", "0 0\n0\n"),
                "line 12: the file ends",
            ),
            (
                good.replace("0 0\n0 0\n", "0 0\n0 300\n"),
                "line 12: cell cost: 300",
            ),
            (
                good.replace("0 0\n0 0\n", "0 0\n0 0 0\n"),
                "line 12: `0` after",
            ),
            (
                good.replace("cellsize(meters): 0.1", "cellsize(meters): 0"),
                "line 5: cellsize must be positive",
            ),
            (
                good.replace("obsthresh: 1", "obsthresh 1"),
                "line 2: expected `obsthresh:`",
            ),
            (good.replace("2 2", "2 -2"), "line 1: height"),
        ] {
            let e = parse_env(&bad)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(e.contains(why), "{bad:?}: {e}");
        }
    }
}
