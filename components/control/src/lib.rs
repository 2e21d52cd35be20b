//! Path following for a skid-steer rover.
//!
//! A pure-pursuit controller steers toward the point of the path one
//! lookahead distance ahead; the body command (speed, yaw rate) becomes wheel
//! speeds through the skid-steer model. Paths have a fixed capacity so the
//! controller never allocates. [`limits`] bounds the command's
//! accelerations; [`safety`] stops the rover before it leaves the map,
//! tips or digs in.

pub mod driver;
pub mod legs;
pub mod limits;
mod mls_probe;
pub mod plan_follower;
pub mod safety;

pub use driver::{ControlCounters, Driver};
pub use legs::{split_legs, Leg, MAX_LEGS};
pub use limits::{AccelLimiter, AccelLimits};
pub use mls_probe::MlsProbe;
pub use plan_follower::{PlanFollower, REVERSE_SPEED_SCALE};
pub use safety::{GroundProbe, Probe, SafetyMonitor, SafetyParams, StopReason};

/// Most waypoints in one path.
pub const MAX_WAYPOINTS: usize = 512;

pub type Path = heapless::Vec<[f64; 2], MAX_WAYPOINTS>;

#[derive(Clone, Debug, PartialEq)]
pub struct FollowerParams {
    pub lookahead_m: f64,
    pub cruise_speed: f64,
    pub max_yaw_rate: f64,
    /// Stop within this distance of the last waypoint of an open path.
    pub goal_tolerance_m: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct SkidSteer {
    pub wheel_radius_m: f64,
    pub track_width_m: f64,
    pub skid_factor: f64,
    pub max_wheel_speed: f64,
}

impl SkidSteer {
    /// Wheel speeds (rad/s; front left, front right, rear left, rear right)
    /// for body speed `v` (m/s) and yaw rate `w` (rad/s). When a wheel would
    /// exceed its limit, both are scaled down together so the curvature is kept.
    pub fn wheel_speeds(&self, v: f64, w: f64) -> [f64; 4] {
        let half = 0.5 * self.track_width_m * self.skid_factor * w;
        let mut left = (v - half) / self.wheel_radius_m;
        let mut right = (v + half) / self.wheel_radius_m;
        let peak = left.abs().max(right.abs());
        if peak > self.max_wheel_speed {
            let s = self.max_wheel_speed / peak;
            left *= s;
            right *= s;
        }
        [left, right, left, right]
    }
}

/// Body command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Twist {
    pub v: f64,
    pub w: f64,
}

#[derive(Clone, Debug)]
pub struct PurePursuit {
    p: FollowerParams,
    path: Path,
    looped: bool,
    /// Index of the segment the rover is on.
    segment: usize,
    done: bool,
}

impl PurePursuit {
    pub fn new(p: FollowerParams, path: Path, looped: bool) -> Self {
        PurePursuit {
            p,
            path,
            looped,
            segment: 0,
            done: false,
        }
    }

    pub fn done(&self) -> bool {
        self.done
    }

    /// Follow `path` from its start (a new plan).
    pub fn set_path(&mut self, path: Path, looped: bool) {
        self.path = path;
        self.looped = looped;
        self.segment = 0;
        self.done = false;
    }

    /// Stop following: the path counts as ended.
    pub fn abandon(&mut self) {
        self.done = true;
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Path length left from the rover's projection on its segment, m
    /// (infinite on a loop).
    pub fn remaining_m(&self, x: f64, y: f64) -> f64 {
        if self.looped {
            return f64::INFINITY;
        }
        if self.done || self.segments() == 0 {
            return 0.0;
        }
        let (_, _, len, t) = self.project(x, y);
        let mut left = (1.0 - t) * len;
        for i in self.segment + 1..self.segments() {
            let (a, b) = self.seg(i);
            left += libm::hypot(b[0] - a[0], b[1] - a[1]);
        }
        left
    }

    /// Distance from (x, y) to the current segment, m.
    pub fn cross_track_m(&self, x: f64, y: f64) -> f64 {
        if self.segments() == 0 {
            return 0.0;
        }
        let (a, d, _, t) = self.project(x, y);
        libm::hypot(a[0] + t * d[0] - x, a[1] + t * d[1] - y)
    }

    /// The current segment's start and direction (end - start), its length,
    /// and where (x, y) projects on it as a fraction clamped to [0, 1] (1
    /// on a zero-length segment).
    fn project(&self, x: f64, y: f64) -> ([f64; 2], [f64; 2], f64, f64) {
        let (a, b) = self.seg(self.segment);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = libm::hypot(dx, dy);
        let t = if len > 0.0 {
            (((x - a[0]) * dx + (y - a[1]) * dy) / (len * len)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        (a, [dx, dy], len, t)
    }

    pub fn segment(&self) -> usize {
        self.segment
    }

    fn seg(&self, i: usize) -> ([f64; 2], [f64; 2]) {
        let n = self.path.len();
        (self.path[i % n], self.path[(i + 1) % n])
    }

    fn segments(&self) -> usize {
        if self.looped {
            self.path.len()
        } else {
            self.path.len().saturating_sub(1)
        }
    }

    /// Command for the rover at (x, y) heading `yaw`.
    pub fn command(&mut self, x: f64, y: f64, yaw: f64) -> Twist {
        let stop = Twist { v: 0.0, w: 0.0 };
        if self.done || self.segments() == 0 {
            return stop;
        }
        // Advance past segments whose end is behind the rover or reached (a
        // hairpin's tip may never be passed: the rover turns short of it).
        loop {
            let (a, b) = self.seg(self.segment);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len2 = dx * dx + dy * dy;
            let t = if len2 > 0.0 {
                ((x - a[0]) * dx + (y - a[1]) * dy) / len2
            } else {
                1.0
            };
            let last = !self.looped && self.segment + 1 >= self.segments();
            let reached = libm::hypot(b[0] - x, b[1] - y) < 0.5 * self.p.lookahead_m;
            if (t < 1.0 && !reached) || last {
                break;
            }
            self.segment = (self.segment + 1) % self.segments();
        }
        // Only on the last segment: a path out and back ends where it starts.
        if !self.looped && self.segment + 1 >= self.segments() {
            let goal = self.path[self.path.len() - 1];
            if libm::hypot(goal[0] - x, goal[1] - y) < self.p.goal_tolerance_m {
                self.done = true;
                return stop;
            }
        }
        let target = self.lookahead_point(x, y);
        // Target in the body frame.
        let (s, c) = (libm::sin(yaw), libm::cos(yaw));
        let (dx, dy) = (target[0] - x, target[1] - y);
        let bx = c * dx + s * dy;
        let by = -s * dx + c * dy;
        let l2 = (bx * bx + by * by).max(1e-9);
        let curvature = 2.0 * by / l2;
        // Turn on the spot first when the target is behind.
        let v = if bx < 0.0 { 0.0 } else { self.p.cruise_speed };
        let w = if v == 0.0 {
            libm::copysign(self.p.max_yaw_rate, by)
        } else {
            (v * curvature).clamp(-self.p.max_yaw_rate, self.p.max_yaw_rate)
        };
        // Slow down in sharp turns so the yaw limit keeps the curvature.
        let v = if v > 0.0 && (v * curvature).abs() > self.p.max_yaw_rate {
            self.p.max_yaw_rate / curvature.abs()
        } else {
            v
        };
        Twist { v, w }
    }

    /// The point one lookahead ahead along the path from the rover's projection.
    fn lookahead_point(&self, x: f64, y: f64) -> [f64; 2] {
        let mut remaining = self.p.lookahead_m;
        let (a, d, _, t) = self.project(x, y);
        let mut p = [a[0] + t * d[0], a[1] + t * d[1]];
        let mut i = self.segment;
        for _ in 0..self.path.len() + 1 {
            let (_, b) = self.seg(i);
            let d = libm::hypot(b[0] - p[0], b[1] - p[1]);
            if d >= remaining {
                let f = remaining / d;
                return [p[0] + f * (b[0] - p[0]), p[1] + f * (b[1] - p[1])];
            }
            remaining -= d;
            p = b;
            i += 1;
            if !self.looped && i >= self.segments() {
                return p;
            }
        }
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> FollowerParams {
        FollowerParams {
            lookahead_m: 0.8,
            cruise_speed: 0.5,
            max_yaw_rate: 0.8,
            goal_tolerance_m: 0.2,
        }
    }

    fn path(points: &[[f64; 2]]) -> Path {
        let mut p = Path::new();
        for q in points {
            let _ = p.push(*q);
        }
        p
    }

    /// Drive a unicycle with the controller's commands.
    fn drive(pp: &mut PurePursuit, steps: usize) -> (f64, f64, f64) {
        let (mut x, mut y, mut yaw) = (0.0, 0.0, 0.0);
        let dt = 0.02;
        for _ in 0..steps {
            let t = pp.command(x, y, yaw);
            yaw += t.w * dt;
            x += t.v * yaw.cos() * dt;
            y += t.v * yaw.sin() * dt;
        }
        (x, y, yaw)
    }

    #[test]
    fn reaches_the_end_of_an_open_path() {
        let mut pp = PurePursuit::new(params(), path(&[[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]]), false);
        let (x, y, _) = drive(&mut pp, 3000);
        assert!(pp.done());
        assert!((x - 4.0).abs() < 0.3 && (y - 3.0).abs() < 0.3, "{x} {y}");
    }

    #[test]
    fn an_out_and_back_path_turns_at_its_far_end_and_ends_home() {
        let out_back = path(&[[0.0, 0.0], [3.0, 0.0], [6.0, 0.5], [3.0, 0.0], [0.0, 0.0]]);
        let mut pp = PurePursuit::new(params(), out_back, false);
        // Starting on the goal does not end the path.
        assert!(pp.command(0.0, 0.0, 0.0).v > 0.0);
        let (x, y, _) = drive(&mut pp, 6000);
        assert!(pp.done());
        assert!(x.abs() < 0.3 && y.abs() < 0.3, "{x} {y}");
    }

    #[test]
    fn turns_toward_a_target_behind() {
        let mut pp = PurePursuit::new(params(), path(&[[0.0, 0.0], [-3.0, 0.1]]), false);
        let t = pp.command(0.0, 0.0, 0.0);
        assert_eq!(t.v, 0.0);
        assert!(t.w.abs() > 0.0);
    }

    #[test]
    fn loops_keep_going() {
        let square = path(&[[0.0, 0.0], [3.0, 0.0], [3.0, 3.0], [0.0, 3.0]]);
        let mut pp = PurePursuit::new(params(), square, true);
        drive(&mut pp, 6000);
        assert!(!pp.done());
    }

    #[test]
    fn wheel_speeds_keep_curvature_under_the_limit() {
        let s = SkidSteer {
            wheel_radius_m: 0.2,
            track_width_m: 0.5,
            skid_factor: 1.0,
            max_wheel_speed: 2.0,
        };
        let w = s.wheel_speeds(1.0, 1.0);
        assert!((w[1] - 2.0).abs() < 1e-12);
        assert!((w[0] / w[1] - 0.75 / 1.25).abs() < 1e-12);
        assert_eq!(w[0], w[2]);
    }
}
