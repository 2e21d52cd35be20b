//! Following a plan leg by leg (see [`crate::legs`]): the control task
//! drives the rover with it, and the internal simulator drives the
//! simulated rover with a clone of it, so both follow a plan alike.

use crate::legs::{split_legs, Leg, MAX_LEGS};
use crate::{FollowerParams, Path, PurePursuit, Twist, MAX_WAYPOINTS};

/// Backward legs are driven at this fraction of the forward command.
pub const REVERSE_SPEED_SCALE: f64 = 0.5;

#[derive(Clone, Debug)]
pub struct PlanFollower {
    follower: PurePursuit,
    /// The plan's poses (x, y, heading), its legs and the leg being driven.
    poses: heapless::Vec<[f64; 3], MAX_WAYPOINTS>,
    legs: heapless::Vec<Leg, MAX_LEGS>,
    leg: usize,
    /// Per leg, the length of the legs after it, m (set with the plan).
    left_after: heapless::Vec<f64, MAX_LEGS>,
}

impl PlanFollower {
    /// A follower with nothing to follow.
    pub fn new(p: FollowerParams) -> Self {
        let mut follower = PurePursuit::new(p, Path::new(), false);
        follower.abandon();
        PlanFollower {
            follower,
            poses: heapless::Vec::new(),
            legs: heapless::Vec::new(),
            leg: 0,
            left_after: heapless::Vec::new(),
        }
    }

    /// Follow `poses` (x, y, heading) from the first; false when they do
    /// not move (already there: nothing to follow).
    pub fn set_plan(&mut self, poses: impl IntoIterator<Item = [f64; 3]>) -> bool {
        self.poses.clear();
        for p in poses {
            if self.poses.push(p).is_err() {
                break;
            }
        }
        split_legs(&self.poses, &mut self.legs);
        self.left_after.clear();
        let mut after = 0.0;
        for l in self.legs.iter().rev() {
            let _ = self.left_after.push(after);
            after += self.poses[l.start..=l.end]
                .windows(2)
                .map(|w| libm::hypot(w[1][0] - w[0][0], w[1][1] - w[0][1]))
                .sum::<f64>();
        }
        self.left_after.reverse();
        self.leg = 0;
        if self.start_leg() {
            true
        } else {
            self.follower.abandon();
            false
        }
    }

    fn start_leg(&mut self) -> bool {
        let Some(l) = self.legs.get(self.leg).copied() else {
            return false;
        };
        let mut path = Path::new();
        for p in &self.poses[l.start..=l.end] {
            let q = [p[0], p[1]];
            if path.last() != Some(&q) && path.push(q).is_err() {
                break;
            }
        }
        if path.len() < 2 {
            return false;
        }
        self.follower.set_path(path, false);
        true
    }

    /// The leg being driven is driven backward.
    pub fn reversing(&self) -> bool {
        self.legs.get(self.leg).is_some_and(|l| l.reverse)
    }

    /// The command for the rover at (x, y) heading `yaw`; the next leg
    /// when this one is done.
    pub fn command(&mut self, x: f64, y: f64, yaw: f64) -> Twist {
        loop {
            // Backward: pure pursuit for the rover turned about.
            let reverse = self.reversing();
            let heading = if reverse {
                yaw + core::f64::consts::PI
            } else {
                yaw
            };
            let mut t = self.follower.command(x, y, heading);
            if reverse {
                // Backing up, slower (same curvature): pure pursuit strays
                // more, the monitor looks behind less well, and the planner
                // costs reversing at under half the forward speed.
                t.v = -t.v * REVERSE_SPEED_SCALE;
                t.w *= REVERSE_SPEED_SCALE;
            }
            if !self.follower.done() || self.leg + 1 >= self.legs.len() {
                return t;
            }
            self.leg += 1;
            if !self.start_leg() {
                return t;
            }
        }
    }

    pub fn done(&self) -> bool {
        self.follower.done()
    }

    pub fn abandon(&mut self) {
        self.follower.abandon();
    }

    pub fn segment(&self) -> usize {
        self.follower.segment()
    }

    /// Left on the current leg, m.
    pub fn remaining_m(&self, x: f64, y: f64) -> f64 {
        self.follower.remaining_m(x, y)
    }

    /// The whole plan left to drive, m: the current leg's rest and every
    /// later leg; zero once done.
    pub fn plan_left_m(&self, x: f64, y: f64) -> f64 {
        if self.done() {
            return 0.0;
        }
        let later = self.left_after.get(self.leg).copied().unwrap_or(0.0);
        self.remaining_m(x, y) + later
    }

    pub fn cross_track_m(&self, x: f64, y: f64) -> f64 {
        self.follower.cross_track_m(x, y)
    }

    /// The plan's last pose.
    pub fn goal(&self) -> Option<[f64; 3]> {
        self.poses.last().copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    #[test]
    fn the_plan_left_counts_every_later_leg_and_shrinks_leg_by_leg() {
        let mut f = PlanFollower::new(FollowerParams {
            lookahead_m: 0.8,
            cruise_speed: 0.4,
            max_yaw_rate: 0.8,
            goal_tolerance_m: 0.2,
        });
        // A three-point turn: 2 m forward, 0.5 m back, 1.6 m forward.
        let poses = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [1.6, -0.3, 0.8],
            [1.6, -0.3, 1.6],
            [1.0, 0.0, PI],
            [0.0, 0.0, PI],
        ];
        assert!(f.set_plan(poses));
        let back = 0.5;
        let out = 0.6f64.hypot(0.3) + 1.0;
        assert!((f.plan_left_m(0.0, 0.0) - (2.0 + back + out)).abs() < 1e-9);
        // Halfway along the first leg.
        assert!((f.plan_left_m(1.0, 0.0) - (1.0 + back + out)).abs() < 1e-9);
        // On the last leg, only its rest.
        f.leg = 2;
        assert!(f.start_leg());
        assert!((f.plan_left_m(1.0, 0.0) - 1.0).abs() < 1e-9);
        f.abandon();
        assert_eq!(f.plan_left_m(1.0, 0.0), 0.0);
    }
}
