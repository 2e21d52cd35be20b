//! The safety monitor: the rover is stopped before it leaves the part of
//! the map it can drive on, when it tilts too far, when it has strayed
//! from its path, when it is stuck (commanded motion without progress), or
//! when it drives without getting any nearer its plan's end (circling a goal
//! it cannot settle on).
//! The paper's exploration depends on it: terrain in a cave is unknown, the
//! rover slips and skids, and a stop is followed by fresh maps and a new
//! plan.
//!
//! The map is reached through [`GroundProbe`], so the monitor is tested on
//! synthetic ground and runs on board over the MLS map.

/// What the map says about a point ahead at the expected ground height.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Probe {
    /// Ground within the tolerance.
    Ground,
    /// No ground seen there: unobserved, or a ring gap.
    NoGround,
    /// No ground near the height, only ground seen from above far below:
    /// the rim of a ledge or a ramp's open side.
    Drop,
    /// Something at body height over the ground.
    Blocked,
}

/// The map as the monitor sees it.
pub trait GroundProbe {
    /// Whether there is ground at (`x`, `y`) within `tol_m` of height `z`.
    fn probe(&self, x: f64, y: f64, z: f64, tol_m: f64) -> Probe;
}

pub use speleo_messages::StopReason;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SafetyParams {
    pub max_tilt_deg: f64,
    /// Stuck: commanded motion for this long ...
    pub stuck_after_s: f64,
    /// ... without moving this far or turning this much.
    pub stuck_progress_m: f64,
    pub stuck_turn_rad: f64,
    /// No progress: the plan left to drive has not shrunk by
    /// `stuck_progress_m` in this long, s. Turning on the spot counts as
    /// motion for the stuck test, so a rover circling a goal it overshoots
    /// is caught only here.
    pub no_progress_after_s: f64,
    /// From base_link to the front of the wheels, m.
    pub front_m: f64,
    /// From the centre line to each side's wheels, m (half the track).
    pub half_track_m: f64,
    /// How far beyond the front the ground is probed, and in which steps, m.
    pub probe_ahead_m: f64,
    pub probe_step_m: f64,
    /// The longest stretch without ground that counts as a sensor gap, m
    /// (the HDL-32E's rings leave gaps on the ground).
    pub max_gap_m: f64,
    /// The longest stretch of drop that counts as noise (a fleck of floor
    /// seen through a crack), m; a drop is an edge even where the plan
    /// began.
    pub max_drop_m: f64,
    /// Within this much of the front, something at body height stops the
    /// rover, m.
    pub blocked_within_m: f64,
    /// Ground height tolerance: a step, plus the slope over the distance.
    pub max_step_m: f64,
    pub max_slope_deg: f64,
    /// Ground under base_link, m.
    pub base_height_m: f64,
    pub max_cross_track_m: f64,
    /// Around where a plan began, no ground seen is not an edge, m.
    pub blind_radius_m: f64,
}

impl Default for SafetyParams {
    fn default() -> Self {
        SafetyParams {
            max_tilt_deg: 30.0,
            stuck_after_s: 5.0,
            stuck_progress_m: 0.15,
            stuck_turn_rad: 0.3,
            no_progress_after_s: 30.0,
            front_m: 0.5,
            half_track_m: 0.26,
            probe_ahead_m: 0.8,
            probe_step_m: 0.1,
            max_gap_m: 0.6,
            max_drop_m: 0.15,
            blocked_within_m: 0.2,
            max_step_m: 0.2,
            max_slope_deg: 30.0,
            base_height_m: 0.19,
            max_cross_track_m: 0.8,
            blind_radius_m: 1.2,
        }
    }
}

/// The rover's state as the monitor needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MonitorInput {
    pub t_s: f64,
    /// base_link in the map frame, m, and its heading, rad.
    pub position: [f64; 3],
    pub yaw: f64,
    /// Angle between the body's up axis and the vertical, deg.
    pub tilt_deg: f64,
    /// The command about to be sent.
    pub v: f64,
    pub w: f64,
    /// Path left on the current leg, and the distance from the path, m.
    pub remaining_m: f64,
    pub cross_track_m: f64,
    /// The whole plan left to drive, m (infinite on a loop: never checked).
    pub plan_left_m: f64,
}

/// See the module documentation.
#[derive(Clone, Debug)]
pub struct SafetyMonitor {
    p: SafetyParams,
    /// Where and when the current stretch of commanded motion was last
    /// seen to make progress.
    anchor: Option<(f64, [f64; 2], f64)>,
    /// The tilt at the first check since the last reset.
    start_tilt_deg: Option<f64>,
    /// Where the rover stood at the last reset (a plan's start).
    start_xy: Option<[f64; 2]>,
    /// When the plan left to drive was last seen to shrink, and its
    /// smallest value since the reset.
    best_left: Option<(f64, f64)>,
    /// Where the probe that made the last check's map stop looked (see
    /// [`trigger`](Self::trigger)).
    trigger: Option<[f64; 2]>,
    /// The probe there saw a drop, not only no ground.
    trigger_drop: bool,
}

/// A rover already tilted beyond the limit (stopped there) may move as
/// long as the tilt does not grow by more than this, deg: it can only get
/// off the slope by moving.
pub const TILT_GROWTH_DEG: f64 = 2.0;
/// Beyond the tilt limit by this much, the rover does not move at all, deg.
pub const TILT_HARD_MARGIN_DEG: f64 = 12.0;

/// The tilt past which a plan that began at `start_deg` is stopped, deg:
/// `limit_deg`, or the start's tilt plus [`TILT_GROWTH_DEG`] where that is
/// more (a rover stopped on a slope can only get off it by moving), and
/// never past the hard margin. The internal simulation judges its runs by
/// the same rule, so that it refuses what the monitor would stop.
pub fn tilt_stop_deg(limit_deg: f64, start_deg: f64) -> f64 {
    limit_deg
        .max(start_deg + TILT_GROWTH_DEG)
        .min(limit_deg + TILT_HARD_MARGIN_DEG)
}

impl SafetyMonitor {
    pub fn new(p: SafetyParams) -> Self {
        SafetyMonitor {
            p,
            anchor: None,
            start_tilt_deg: None,
            start_xy: None,
            best_left: None,
            trigger: None,
            trigger_drop: false,
        }
    }

    pub fn params(&self) -> &SafetyParams {
        &self.p
    }

    /// Forget the motion history (a new plan).
    pub fn reset(&mut self) {
        self.anchor = None;
        self.start_tilt_deg = None;
        self.start_xy = None;
        self.best_left = None;
    }

    /// Where the probe that made the last check's `LeavingMap` or
    /// `Blocked` stop looked (x, y in the map frame): the map cell that
    /// explains it. None after any other check.
    pub fn trigger(&self) -> Option<[f64; 2]> {
        self.trigger
    }

    /// Whether the last check's `LeavingMap` stop saw a drop at its
    /// [`trigger`](Self::trigger) (ground far under the rover's: a rim),
    /// rather than ground unseen for too long.
    pub fn trigger_saw_drop(&self) -> bool {
        self.trigger_drop
    }

    /// Whether the command must not be sent, and why.
    pub fn check(&mut self, s: &MonitorInput, map: &impl GroundProbe) -> Option<StopReason> {
        self.trigger = None;
        self.trigger_drop = false;
        let start = *self.start_tilt_deg.get_or_insert(s.tilt_deg);
        self.start_xy.get_or_insert([s.position[0], s.position[1]]);
        // Over the limit, a plan that began there may go on while the tilt
        // does not grow (off the slope); past the hard limit nothing moves
        // (in the garage, plan after plan each walked the rover a few
        // degrees further up a ramp's side, until it turned over).
        if s.tilt_deg > tilt_stop_deg(self.p.max_tilt_deg, start) {
            return Some(StopReason::Tilt);
        }
        if self.stuck(s) {
            return Some(StopReason::Stuck);
        }
        if self.no_progress(s) {
            return Some(StopReason::NoProgress);
        }
        if s.cross_track_m > self.p.max_cross_track_m {
            return Some(StopReason::OffPath);
        }
        let (reason, at, drop) = self.ahead(s, map)?;
        self.trigger = Some(at);
        self.trigger_drop = drop;
        Some(reason)
    }

    fn stuck(&mut self, s: &MonitorInput) -> bool {
        let commanded = s.v.abs() > 0.05 || s.w.abs() > 0.2;
        if !commanded {
            self.anchor = None;
            return false;
        }
        let here = [s.position[0], s.position[1]];
        let Some((t0, at, yaw0)) = self.anchor else {
            self.anchor = Some((s.t_s, here, s.yaw));
            return false;
        };
        let moved = libm::hypot(here[0] - at[0], here[1] - at[1]);
        let turned = wrap(s.yaw - yaw0).abs();
        if moved > self.p.stuck_progress_m || turned > self.p.stuck_turn_rad {
            self.anchor = Some((s.t_s, here, s.yaw));
            return false;
        }
        s.t_s - t0 > self.p.stuck_after_s
    }

    fn no_progress(&mut self, s: &MonitorInput) -> bool {
        if !s.plan_left_m.is_finite() {
            return false;
        }
        match self.best_left {
            Some((t0, best)) if s.plan_left_m > best - self.p.stuck_progress_m => {
                s.t_s - t0 > self.p.no_progress_after_s
            }
            _ => {
                self.best_left = Some((s.t_s, s.plan_left_m));
                false
            }
        }
    }

    /// The ground ahead in the direction of travel, up to the end of the
    /// path: under the front of the wheels as the rover drives on along
    /// the arc of its command. Probed straight ahead, a rover turning hard
    /// round a wall's end saw the wall it was turning away from, and was
    /// stopped there plan after plan (1,276 times in one lava-tube run).
    /// The stop, the probe that made it and whether that probe saw a drop.
    fn ahead(
        &self,
        s: &MonitorInput,
        map: &impl GroundProbe,
    ) -> Option<(StopReason, [f64; 2], bool)> {
        if s.v.abs() < 0.01 {
            return None;
        }
        let dir = if s.v > 0.0 { 1.0 } else { -1.0 };
        // Heading change per metre driven.
        let curvature = s.w / s.v.abs();
        // Where the front of the wheels is after d metres along the arc,
        // `side` metres to the left of the centre line.
        let front_at = |d: f64, side: f64| {
            let h = s.yaw + curvature * d;
            let (sn, cs) = (libm::sin(h), libm::cos(h));
            // Where base_link is after d metres along the arc...
            let (bx, by) = if (curvature * d).abs() < 1e-6 {
                (d * libm::cos(s.yaw), d * libm::sin(s.yaw))
            } else {
                (
                    (sn - libm::sin(s.yaw)) / curvature,
                    (libm::cos(s.yaw) - cs) / curvature,
                )
            };
            // ...and the front of its wheels, in the direction of travel.
            (
                s.position[0] + dir * (bx + self.p.front_m * cs) - side * sn,
                s.position[1] + dir * (by + self.p.front_m * sn) + side * cs,
            )
        };
        let front = |d: f64| front_at(d, 0.0);
        let ground = s.position[2] - self.p.base_height_m;
        let slope = libm::tan(self.p.max_slope_deg.to_radians());
        // Beyond the path's end the rover will not go.
        let reach = self.p.probe_ahead_m.min(s.remaining_m.max(0.0));
        let steps = (reach / self.p.probe_step_m).floor() as usize;
        let (mut gap, mut drop) = (0.0, 0.0);
        let mut side_drop = [0.0; 2];
        for k in 0..=steps {
            let d = k as f64 * self.p.probe_step_m;
            let r = self.p.front_m + d;
            // Under each side's wheels only a drop seen counts: a plan
            // along a slab's edge keeps its centre line on the slab while
            // one side's wheels go over (the garage's ramp opening), and
            // ground merely unseen beside the path is a ring gap.
            for (i, side) in [self.p.half_track_m, -self.p.half_track_m]
                .into_iter()
                .enumerate()
            {
                let (x, y) = front_at(d, side);
                let tol = self.p.max_step_m + (r + self.p.half_track_m) * slope;
                if map.probe(x, y, ground, tol) == Probe::Drop {
                    side_drop[i] += self.p.probe_step_m;
                    if side_drop[i] > self.p.max_drop_m {
                        return Some((StopReason::LeavingMap, [x, y], true));
                    }
                } else {
                    side_drop[i] = 0.0;
                }
            }
            let (x, y) = front(d);
            let probe = map.probe(x, y, ground, self.p.max_step_m + r * slope);
            if probe == Probe::Drop {
                // Seen, so not the blind ring around the plan's start: a
                // garage rover turning round at a ramp's open side, within
                // that ring, drove off it.
                drop += self.p.probe_step_m;
                if drop > self.p.max_drop_m {
                    return Some((StopReason::LeavingMap, [x, y], true));
                }
            } else {
                drop = 0.0;
            }
            match probe {
                Probe::Ground => gap = 0.0,
                // The LiDAR never sees the ground around where the rover
                // stood still (its lowest beam meets it ~1 m away): no
                // ground there is no edge.
                Probe::NoGround if self.in_blind_zone(x, y) => gap = 0.0,
                Probe::NoGround | Probe::Drop => {
                    gap += self.p.probe_step_m;
                    if gap > self.p.max_gap_m {
                        return Some((StopReason::LeavingMap, [x, y], probe == Probe::Drop));
                    }
                }
                Probe::Blocked if d <= self.p.blocked_within_m => {
                    return Some((StopReason::Blocked, [x, y], false));
                }
                Probe::Blocked => gap = 0.0,
            }
        }
        // A gap still open where the path ends lies under the wheels when
        // the rover stands there: it is a sensor gap only if the ground
        // resumes within `max_gap_m` beyond. A garage rover sent to a
        // frontier at a ramp's opening, whose far side the slab hid, stood
        // with its front wheels over the 2.4 m drop and turned over.
        if gap > 0.0 && s.remaining_m < self.p.probe_ahead_m {
            let more = libm::ceil(self.p.max_gap_m / self.p.probe_step_m) as usize + 1;
            for k in steps + 1..=steps + more {
                let d = k as f64 * self.p.probe_step_m;
                let r = self.p.front_m + d;
                let (x, y) = front(d);
                let probe = map.probe(x, y, ground, self.p.max_step_m + r * slope);
                match probe {
                    Probe::Ground | Probe::Blocked => break,
                    Probe::NoGround if self.in_blind_zone(x, y) => break,
                    Probe::NoGround | Probe::Drop => {
                        gap += self.p.probe_step_m;
                        if gap > self.p.max_gap_m {
                            return Some((StopReason::LeavingMap, [x, y], probe == Probe::Drop));
                        }
                    }
                }
            }
        }
        None
    }
}

impl SafetyMonitor {
    fn in_blind_zone(&self, x: f64, y: f64) -> bool {
        self.start_xy
            .is_some_and(|s| libm::hypot(x - s[0], y - s[1]) < self.p.blind_radius_m)
    }
}

fn wrap(a: f64) -> f64 {
    let tau = core::f64::consts::TAU;
    a - tau * libm::floor((a + core::f64::consts::PI) / tau)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Flat ground at z = 0 for x < `edge`, nothing beyond; a wall at
    /// x = `wall` when set.
    struct Ledge {
        edge: f64,
        wall: Option<f64>,
    }

    impl GroundProbe for Ledge {
        fn probe(&self, x: f64, _y: f64, z: f64, tol: f64) -> Probe {
            if self.wall.is_some_and(|w| x >= w) {
                return Probe::Blocked;
            }
            if x < self.edge && z.abs() <= tol {
                Probe::Ground
            } else {
                Probe::NoGround
            }
        }
    }

    fn input(x: f64, t: f64) -> MonitorInput {
        MonitorInput {
            t_s: t,
            position: [x, 0.0, 0.19],
            yaw: 0.0,
            tilt_deg: 2.0,
            v: 0.3,
            w: 0.0,
            remaining_m: 10.0,
            cross_track_m: 0.0,
            plan_left_m: 10.0 - x,
        }
    }

    #[test]
    fn driving_toward_an_edge_stops_before_the_wheels_reach_it() {
        let map = Ledge {
            edge: 5.0,
            wall: None,
        };
        let mut m = SafetyMonitor::new(SafetyParams::default());
        let mut x = 0.0;
        let mut t = 0.0;
        let stop = loop {
            if let Some(r) = m.check(&input(x, t), &map) {
                break r;
            }
            x += 0.3 * 0.02;
            t += 0.02;
            assert!(x < 6.0, "never stopped");
        };
        assert_eq!(stop, StopReason::LeavingMap);
        // The front of the wheels is still on the ground.
        assert!(x + SafetyParams::default().front_m < 5.0, "stopped at {x}");
        // The probe that stopped it looked past the edge, ahead of the
        // wheels; the next check (a new plan) forgets it.
        let [px, _] = m.trigger().expect("the stop's probe");
        assert!(px > 5.0 && px < x + 2.0, "probe at {px}");
        // Nothing was seen beyond the edge: no drop seen, no rim.
        assert!(!m.trigger_saw_drop());
        m.reset();
        assert_eq!(
            m.check(
                &input(0.0, t + 100.0),
                &Ledge {
                    edge: 50.0,
                    wall: None
                }
            ),
            None
        );
        assert_eq!(m.trigger(), None);
    }

    #[test]
    fn a_gap_shorter_than_a_ring_gap_and_the_paths_end_do_not_stop() {
        struct Gappy;
        impl GroundProbe for Gappy {
            fn probe(&self, x: f64, _y: f64, _z: f64, _tol: f64) -> Probe {
                if (2.0..2.45).contains(&x) {
                    Probe::NoGround
                } else {
                    Probe::Ground
                }
            }
        }
        let mut m = SafetyMonitor::new(SafetyParams::default());
        for k in 0..100 {
            assert_eq!(
                m.check(&input(k as f64 * 0.03, k as f64 * 0.1), &Gappy),
                None
            );
        }
        // The path ends short of the edge: nothing beyond it is probed.
        let map = Ledge {
            edge: 5.0,
            wall: None,
        };
        let mut near_end = input(4.2, 0.0);
        near_end.remaining_m = 0.2;
        assert_eq!(m.check(&near_end, &map), None);
    }

    #[test]
    fn a_path_ending_with_the_wheels_over_unseen_ground_stops_unless_it_resumes() {
        // The path ends with base_link at 4.8 m, the front of the wheels at
        // 5.3 m: 0.3 m past the last ground seen, less than a ring gap.
        let mut at = input(4.2, 0.0);
        at.remaining_m = 0.6;
        let edge = Ledge {
            edge: 5.0,
            wall: None,
        };
        // The plan began 4 m back, out of reach of the blind ring.
        let began = |map: &dyn Fn(&mut SafetyMonitor) -> Option<StopReason>| {
            let mut m = SafetyMonitor::new(SafetyParams::default());
            m.check(
                &input(0.2, 0.0),
                &Ledge {
                    edge: 9.0,
                    wall: None,
                },
            );
            map(&mut m)
        };
        assert_eq!(
            began(&|m| m.check(&at, &edge)),
            Some(StopReason::LeavingMap)
        );
        // The same stretch with ground again at 5.4 m is a ring gap.
        struct RingGap;
        impl GroundProbe for RingGap {
            fn probe(&self, x: f64, _y: f64, _z: f64, _tol: f64) -> Probe {
                if (5.0..5.4).contains(&x) {
                    Probe::NoGround
                } else {
                    Probe::Ground
                }
            }
        }
        assert_eq!(began(&|m| m.check(&at, &RingGap)), None);
    }

    #[test]
    fn no_ground_around_where_the_plan_began_is_not_an_edge() {
        // Nothing seen within 1.1 m of the start (the LiDAR's blind ring),
        // ground beyond.
        struct Blind;
        impl GroundProbe for Blind {
            fn probe(&self, x: f64, y: f64, _z: f64, _tol: f64) -> Probe {
                if x.hypot(y) < 1.1 {
                    Probe::NoGround
                } else {
                    Probe::Ground
                }
            }
        }
        let mut m = SafetyMonitor::new(SafetyParams::default());
        assert_eq!(m.check(&input(0.0, 0.0), &Blind), None);
        // Elsewhere the same hole would be an edge.
        let mut far = SafetyMonitor::new(SafetyParams::default());
        let mut s = input(-3.0, 0.0);
        s.position[0] = -2.0;
        assert_eq!(
            far.check(&s, &Blind),
            None,
            "1 m of hole is bridged by the ring gap rule"
        );
    }

    #[test]
    fn a_drop_seen_stops_the_rover_even_where_the_plan_began() {
        // The ramp's open side 1 m ahead of where the plan begins: within
        // the blind ring, but seen as a drop, not as nothing.
        struct Rim(Probe);
        impl GroundProbe for Rim {
            fn probe(&self, x: f64, _y: f64, _z: f64, _tol: f64) -> Probe {
                if x < 1.0 {
                    Probe::Ground
                } else {
                    self.0
                }
            }
        }
        let mut m = SafetyMonitor::new(SafetyParams::default());
        assert_eq!(
            m.check(&input(0.0, 0.0), &Rim(Probe::Drop)),
            Some(StopReason::LeavingMap)
        );
        // The probe saw the drop (a rim the exploration keeps), past 1 m.
        assert!(m.trigger_saw_drop());
        assert!(m.trigger().is_some_and(|[x, _]| x >= 1.0));
        // Unseen ground there is the blind ring, not an edge.
        let mut m = SafetyMonitor::new(SafetyParams::default());
        assert_eq!(m.check(&input(0.0, 0.0), &Rim(Probe::NoGround)), None);
        // A fleck of drop (one probe) is noise.
        struct Fleck;
        impl GroundProbe for Fleck {
            fn probe(&self, x: f64, _y: f64, _z: f64, _tol: f64) -> Probe {
                if (0.95..1.05).contains(&x) {
                    Probe::Drop
                } else {
                    Probe::Ground
                }
            }
        }
        let mut m = SafetyMonitor::new(SafetyParams::default());
        assert_eq!(m.check(&input(0.0, 0.0), &Fleck), None);
    }

    #[test]
    fn a_drop_under_one_sides_wheels_stops_the_rover_on_a_centre_line_on_ground() {
        // A slab's edge along the path, `edge` m to the right of the centre
        // line; beyond it the floor below is seen (`beyond`).
        struct Edge {
            edge: f64,
            beyond: Probe,
        }
        impl GroundProbe for Edge {
            fn probe(&self, x: f64, y: f64, _z: f64, _tol: f64) -> Probe {
                if x > 1.5 && y < -self.edge {
                    self.beyond
                } else {
                    Probe::Ground
                }
            }
        }
        let stop = |edge: f64, beyond: Probe| {
            let map = Edge { edge, beyond };
            let mut m = SafetyMonitor::new(SafetyParams::default());
            (0..100).find_map(|k| m.check(&input(k as f64 * 0.03, k as f64 * 0.1), &map))
        };
        // The right wheels (0.26 m out) over the drop.
        assert_eq!(stop(0.2, Probe::Drop), Some(StopReason::LeavingMap));
        // The edge outside the wheels, or unseen ground beside the path.
        assert_eq!(stop(0.35, Probe::Drop), None);
        assert_eq!(stop(0.2, Probe::NoGround), None);
    }

    #[test]
    fn the_tilt_stop_is_the_limit_or_the_starts_tilt_plus_the_growth_and_never_past_the_hard_margin(
    ) {
        assert_eq!(tilt_stop_deg(30.0, 10.0), 30.0);
        assert_eq!(tilt_stop_deg(30.0, 29.0), 29.0 + TILT_GROWTH_DEG);
        assert_eq!(tilt_stop_deg(30.0, 35.0), 35.0 + TILT_GROWTH_DEG);
        assert_eq!(tilt_stop_deg(30.0, 41.0), 30.0 + TILT_HARD_MARGIN_DEG);
        assert_eq!(
            tilt_stop_deg(30.0, f64::INFINITY),
            30.0 + TILT_HARD_MARGIN_DEG
        );
    }

    #[test]
    fn tilt_wall_and_straying_stop() {
        let flat = Ledge {
            edge: 100.0,
            wall: None,
        };
        let mut m = SafetyMonitor::new(SafetyParams::default());
        let mut s = input(0.0, 0.0);
        assert_eq!(m.check(&s, &flat), None);
        s.tilt_deg = 35.0;
        assert_eq!(m.check(&s, &flat), Some(StopReason::Tilt));
        // Stopped on a slope, the rover may drive off it, not up it.
        m.reset();
        assert_eq!(m.check(&s, &flat), None);
        s.tilt_deg = 33.0;
        assert_eq!(m.check(&s, &flat), None);
        s.tilt_deg = 37.5;
        assert_eq!(m.check(&s, &flat), Some(StopReason::Tilt));
        // Nor, plan after plan, past the hard limit.
        m.reset();
        s.tilt_deg = 41.0;
        assert_eq!(m.check(&s, &flat), None);
        s.tilt_deg = 42.5;
        assert_eq!(m.check(&s, &flat), Some(StopReason::Tilt));
        m.reset();
        s.tilt_deg = 42.5;
        assert_eq!(m.check(&s, &flat), Some(StopReason::Tilt));
        // Begun just under the limit, it may tilt two degrees further.
        m.reset();
        s.tilt_deg = 29.0;
        assert_eq!(m.check(&s, &flat), None);
        s.tilt_deg = 30.9;
        assert_eq!(m.check(&s, &flat), None);
        s.tilt_deg = 31.1;
        assert_eq!(m.check(&s, &flat), Some(StopReason::Tilt));
        m.reset();
        let mut s = input(0.0, 0.0);
        s.cross_track_m = 1.0;
        assert_eq!(m.check(&s, &flat), Some(StopReason::OffPath));
        let wall = Ledge {
            edge: 100.0,
            wall: Some(0.6),
        };
        assert_eq!(m.check(&input(0.0, 0.0), &wall), Some(StopReason::Blocked));
        // Reversing away from the wall is allowed.
        let mut back = input(0.0, 0.0);
        back.v = -0.2;
        assert_eq!(m.check(&back, &wall), None);
    }

    #[test]
    fn the_ground_is_probed_along_the_arc_the_rover_turns_on() {
        // A wall across x >= 0.6 for y < 0.5: straight ahead of a rover at
        // the origin, but not on its left.
        struct WallEnd;
        impl GroundProbe for WallEnd {
            fn probe(&self, x: f64, y: f64, _z: f64, _tol: f64) -> Probe {
                if x >= 0.6 && y < 0.5 {
                    Probe::Blocked
                } else {
                    Probe::Ground
                }
            }
        }
        let mut m = SafetyMonitor::new(SafetyParams::default());
        let mut s = input(0.0, 0.0);
        s.yaw = 0.5;
        assert_eq!(m.check(&s, &WallEnd), Some(StopReason::Blocked));
        // Turning left hard (0.5 m radius), away from it: on.
        m.reset();
        s.w = 0.6;
        assert_eq!(m.check(&s, &WallEnd), None);
        // Turning right, into it: stopped.
        m.reset();
        s.w = -0.6;
        assert_eq!(m.check(&s, &WallEnd), Some(StopReason::Blocked));
        // Reversing on the same arc probes behind: nothing there.
        m.reset();
        s.v = -0.3;
        assert_eq!(m.check(&s, &WallEnd), None);
    }

    #[test]
    fn commanded_motion_without_progress_is_stuck() {
        let flat = Ledge {
            edge: 100.0,
            wall: None,
        };
        let mut m = SafetyMonitor::new(SafetyParams::default());
        let mut stuck_at = None;
        for k in 0..400 {
            let t = k as f64 * 0.02;
            // Creeping at 1 cm/s: commanded 0.3 m/s.
            if let Some(r) = m.check(&input(0.01 * t, t), &flat) {
                stuck_at = Some((t, r));
                break;
            }
        }
        let (t, r) = stuck_at.expect("stuck");
        assert_eq!(r, StopReason::Stuck);
        assert!((5.0..5.1).contains(&t), "{t}");
        // Moving normally never is.
        let mut m = SafetyMonitor::new(SafetyParams::default());
        for k in 0..1000 {
            let t = k as f64 * 0.02;
            assert_eq!(m.check(&input(0.3 * t, t), &flat), None);
        }
        // Standing still as commanded is not stuck either.
        let mut s = input(0.0, 0.0);
        s.v = 0.0;
        for k in 0..1000 {
            s.t_s = k as f64 * 0.02;
            assert_eq!(m.check(&s, &flat), None);
        }
    }
}

#[cfg(test)]
mod no_progress_tests {
    use super::*;

    struct Flat;
    impl GroundProbe for Flat {
        fn probe(&self, _x: f64, _y: f64, _z: f64, _tol: f64) -> Probe {
            Probe::Ground
        }
    }

    /// The rover drives a 0.6 m circle around a goal 0.5 m away, never
    /// within the goal tolerance: always moving and turning, so never
    /// stuck.
    fn circling(t: f64) -> MonitorInput {
        let a = 0.4 * t;
        let (x, y) = (0.6 * a.cos(), 0.6 * a.sin());
        MonitorInput {
            t_s: t,
            position: [x, y, 0.19],
            yaw: a + core::f64::consts::FRAC_PI_2,
            tilt_deg: 2.0,
            v: 0.24,
            w: 0.4,
            remaining_m: (x - 0.5).hypot(y),
            cross_track_m: 0.1,
            plan_left_m: (x - 0.5).hypot(y),
        }
    }

    #[test]
    fn a_rover_circling_its_goal_is_stopped_for_making_no_progress() {
        let p = SafetyParams::default();
        let mut m = SafetyMonitor::new(p);
        let mut t = 0.0;
        let stop = loop {
            if let Some(r) = m.check(&circling(t), &Flat) {
                break r;
            }
            t += 0.02;
            assert!(t < 120.0, "never stopped");
        };
        assert_eq!(stop, StopReason::NoProgress);
        // Not before the first lap's closest pass plus the allowance.
        assert!(
            t > p.no_progress_after_s && t < p.no_progress_after_s + 20.0,
            "{t}"
        );
    }

    #[test]
    fn a_slow_plan_that_keeps_getting_nearer_is_not_stopped() {
        // 1 cm/s (a steep climb), and a 12 s turn on the spot at a cusp.
        let mut m = SafetyMonitor::new(SafetyParams::default());
        for k in 0..10_000 {
            let t = k as f64 * 0.02;
            let turning = (60.0..72.0).contains(&t);
            let driven = if t < 60.0 {
                0.01 * t
            } else {
                0.6 + 0.01 * (t - 72.0).max(0.0)
            };
            let s = MonitorInput {
                t_s: t,
                position: [driven, 0.0, 0.19],
                yaw: if turning { 0.3 * (t - 60.0) } else { 0.0 },
                tilt_deg: 2.0,
                v: if turning { 0.0 } else { 0.01 },
                w: if turning { 0.3 } else { 0.0 },
                remaining_m: 5.0 - driven,
                cross_track_m: 0.0,
                plan_left_m: 5.0 - driven,
            };
            assert_eq!(m.check(&s, &Flat), None, "t = {t}");
        }
    }
}
