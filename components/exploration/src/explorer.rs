//! The exploration behaviour's state: what has been covered, the track
//! home, the goals that failed, and whether the rover is exploring,
//! returning or done.

use crate::coverage::CoverageMap;
use crate::energy::{way_home_wh, PowerModel};
use crate::trail::{Trail, LEVEL_M};

/// Failed goals remembered (older ones are forgotten first).
pub const MAX_REJECTED: usize = 64;

/// After exploring resumed on the way home found nothing it could reach,
/// it does not resume again this near, m: the same patches turn up in the
/// next scan, and the rover went round between the two for good (in the
/// lava tube, 27 m from home, exploring again, retracing away, returning).
pub const RESUME_AGAIN_M: f64 = 5.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExplorerParams {
    /// The rover "has been near" what lies within this radius, m.
    pub coverage_radius_m: f64,
    pub coverage_resolution_m: f64,
    /// Side of the coverage map's square around the start, m.
    pub coverage_extent_m: f64,
    /// Exploring ends after this long, s (the return follows). The
    /// default leaves the mission's default 7200 s half an hour to come
    /// home; each plan's validation in the internal simulator takes
    /// mission time too.
    pub time_limit_s: f64,
    /// ... or when this many queries in a row found nothing to explore
    /// (the maps change between them).
    pub empty_queries_to_return: u32,
    /// Home is reached within this distance, m (estimated). It ends the
    /// mission wherever the rover is, even mid-plan: at 0.4 m the lava
    /// tube's mission ended 0.57 m from the true start. The path follower
    /// stops within 0.2 m of the plan's end, which is home. Across only:
    /// home is on its own level ([`LEVEL_M`](crate::trail::LEVEL_M)).
    pub home_tolerance_m: f64,
    /// Track points kept for the way home, and their spacing, m.
    pub trail_points: usize,
    pub trail_spacing_m: f64,
    /// Exploring ends when the energy drawn and the way home's expected
    /// cost ([`way_home_wh`] with `energy_return_factor`) reach this, Wh;
    /// 0: no budget.
    pub energy_budget_wh: f64,
    /// The way home is expected to cost this many times what the way out
    /// cost a metre.
    pub energy_return_factor: f64,
    /// The rover's draw, for the energy meter that feeds the budget.
    pub power: PowerModel,
}

impl Default for ExplorerParams {
    fn default() -> Self {
        ExplorerParams {
            coverage_radius_m: 3.0,
            coverage_resolution_m: 0.25,
            coverage_extent_m: 600.0,
            time_limit_s: 5400.0,
            empty_queries_to_return: 3,
            home_tolerance_m: 0.25,
            trail_points: 4096,
            trail_spacing_m: 1.0,
            energy_budget_wh: 0.0,
            energy_return_factor: 1.5,
            power: PowerModel::default(),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExplorerPhase {
    Exploring,
    /// Going home, and why.
    Returning(ReturnReason),
    /// Home.
    Finished(ReturnReason),
    /// Over, away from home: the rover cannot move (tilted past the point
    /// where the safety monitor lets any wheel turn).
    Stranded,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReturnReason {
    /// Nothing explorable is reachable.
    Explored,
    TimeLimit,
    /// What is left of the energy budget is what the way home needs.
    Energy,
}

/// See the module documentation.
#[derive(Clone, Debug)]
pub struct Explorer {
    p: ExplorerParams,
    home: [f64; 3],
    coverage: CoverageMap,
    trail: Trail,
    rejected: heapless::Deque<[f64; 2], MAX_REJECTED>,
    /// Scratch: the rejected goals as a slice.
    rejected_flat: heapless::Vec<[f64; 2], MAX_REJECTED>,
    phase: ExplorerPhase,
    empty_queries: u32,
    /// Exploring resumed on the way home and has driven nothing since.
    resumed: bool,
    /// Where the last resumed exploring found nothing reachable.
    resumed_in_vain_at: Option<[f64; 2]>,
    /// The energy drawn so far, Wh, and the distance driven, m (across,
    /// between the points observed).
    energy_used_wh: f64,
    driven_m: f64,
    last_seen: Option<[f64; 3]>,
}

impl Explorer {
    /// Exploration from `home` (base_link in the map frame).
    pub fn new(p: ExplorerParams, home: [f64; 3]) -> Self {
        let mut trail = Trail::new(p.trail_points, p.trail_spacing_m);
        trail.record(home);
        Explorer {
            coverage: CoverageMap::new(
                [home[0], home[1]],
                p.coverage_extent_m,
                p.coverage_resolution_m,
            ),
            trail,
            rejected: heapless::Deque::new(),
            rejected_flat: heapless::Vec::new(),
            phase: ExplorerPhase::Exploring,
            empty_queries: 0,
            resumed: false,
            resumed_in_vain_at: None,
            energy_used_wh: 0.0,
            driven_m: 0.0,
            last_seen: None,
            home,
            p,
        }
    }

    pub fn params(&self) -> &ExplorerParams {
        &self.p
    }

    /// Start over from `home` (the first pose known on board), keeping the
    /// storage taken at construction. Coverage stays centred where it was.
    pub fn restart(&mut self, home: [f64; 3]) {
        self.home = home;
        self.trail.clear();
        self.trail.record(home);
        self.rejected.clear();
        self.rejected_flat.clear();
        self.phase = ExplorerPhase::Exploring;
        self.empty_queries = 0;
        self.resumed = false;
        self.resumed_in_vain_at = None;
        self.driven_m = 0.0;
        self.last_seen = None;
    }

    pub fn phase(&self) -> ExplorerPhase {
        self.phase
    }

    pub fn home(&self) -> [f64; 3] {
        self.home
    }

    pub fn coverage(&self) -> &CoverageMap {
        &self.coverage
    }

    pub fn trail(&self) -> &Trail {
        &self.trail
    }

    /// The energy drawn since the start, Wh (the next [`Self::observe`]
    /// weighs it against the budget).
    pub fn set_energy_used(&mut self, wh: f64) {
        self.energy_used_wh = wh;
    }

    /// Distance driven, m, across.
    pub fn driven_m(&self) -> f64 {
        self.driven_m
    }

    /// The way home from `at` along the track, m.
    pub fn way_home_m(&self, at: [f64; 3]) -> f64 {
        self.trail
            .earliest_near(at, 2.0 * self.p.trail_spacing_m)
            .map_or(0.0, |i| {
                let first = self.trail.points()[i];
                self.trail.length_back_from(i) + (first[0] - at[0]).hypot(first[1] - at[1])
            })
    }

    /// What the way home from `at` is expected to cost, Wh.
    pub fn way_home_wh(&self, at: [f64; 3]) -> f64 {
        way_home_wh(
            self.energy_used_wh,
            self.driven_m,
            self.way_home_m(at),
            self.p.energy_return_factor,
        )
    }

    /// The rover is at `p` at mission time `t_s`.
    pub fn observe(&mut self, t_s: f64, p: [f64; 3]) {
        self.coverage
            .mark(p[0], p[1], p[2], self.p.coverage_radius_m);
        self.trail.record(p);
        if let Some(l) = self.last_seen {
            self.driven_m += (p[0] - l[0]).hypot(p[1] - l[1]);
        }
        self.last_seen = Some(p);
        if self.phase == ExplorerPhase::Exploring && t_s >= self.p.time_limit_s {
            self.phase = ExplorerPhase::Returning(ReturnReason::TimeLimit);
        }
        if self.phase == ExplorerPhase::Exploring
            && self.p.energy_budget_wh > 0.0
            && self.energy_used_wh + self.way_home_wh(p) >= self.p.energy_budget_wh
        {
            self.phase = ExplorerPhase::Returning(ReturnReason::Energy);
        }
        if let ExplorerPhase::Returning(r) = self.phase {
            // On home's level only: a garage rover on its way home crossed
            // over home on the second deck and the mission ended there.
            let d = (p[0] - self.home[0]).hypot(p[1] - self.home[1]);
            if d <= self.p.home_tolerance_m && (p[2] - self.home[2]).abs() <= LEVEL_M {
                self.phase = ExplorerPhase::Finished(r);
            }
        }
    }

    /// The rover cannot move any more: the mission ends where it stands.
    pub fn strand(&mut self) {
        if !matches!(self.phase, ExplorerPhase::Finished(_)) {
            self.phase = ExplorerPhase::Stranded;
        }
    }

    /// A goal that could not be planned to or failed in simulation.
    pub fn reject(&mut self, at: [f64; 2]) {
        if self.rejected.is_full() {
            self.rejected.pop_front();
        }
        let _ = self.rejected.push_back(at);
        self.rejected_flat.clear();
        for r in self.rejected.iter() {
            let _ = self.rejected_flat.push(*r);
        }
    }

    /// Forget the goals rejected so far, and where resumed exploring was
    /// in vain: they may be tried again.
    pub fn forget_rejected(&mut self) {
        self.rejected.clear();
        self.rejected_flat.clear();
        self.resumed_in_vain_at = None;
    }

    pub fn rejected(&self) -> &[[f64; 2]] {
        &self.rejected_flat
    }

    /// A query found candidates (`true`) or none.
    pub fn query_result(&mut self, found: bool) {
        if found {
            self.empty_queries = 0;
            return;
        }
        self.empty_queries += 1;
        if self.phase == ExplorerPhase::Exploring
            && self.empty_queries >= self.p.empty_queries_to_return
        {
            self.phase = ExplorerPhase::Returning(ReturnReason::Explored);
        }
    }

    /// Something explorable turned up on the way home at `at` after
    /// nothing was left: explore again, true. A return for the time limit
    /// stays a return, and so does one within [`RESUME_AGAIN_M`] of where
    /// the last resumed exploring found nothing it could reach.
    pub fn resume(&mut self, at: [f64; 2]) -> bool {
        let in_vain_near = self
            .resumed_in_vain_at
            .is_some_and(|q| (q[0] - at[0]).hypot(q[1] - at[1]) < RESUME_AGAIN_M);
        if self.phase != ExplorerPhase::Returning(ReturnReason::Explored) || in_vain_near {
            return false;
        }
        self.phase = ExplorerPhase::Exploring;
        self.empty_queries = 0;
        self.resumed = true;
        true
    }

    /// A plan is driven: exploring (resumed or not) got somewhere.
    pub fn driven(&mut self) {
        self.resumed = false;
    }

    /// A query found nothing it could reach from `at`. Right after a
    /// resume, the return goes on (true) instead of the rover casting
    /// about for a way on.
    pub fn resumed_in_vain(&mut self, at: [f64; 2]) -> bool {
        self.resumed && self.give_up_here(at)
    }

    /// Exploring from `at` is stuck (no candidate, and every way back the
    /// rover came refused by the simulation): home by plans instead, true.
    /// Exploring does not resume within [`RESUME_AGAIN_M`] of here.
    pub fn give_up_here(&mut self, at: [f64; 2]) -> bool {
        if self.phase != ExplorerPhase::Exploring {
            return false;
        }
        self.resumed = false;
        self.resumed_in_vain_at = Some(at);
        self.phase = ExplorerPhase::Returning(ReturnReason::Explored);
        true
    }

    /// Going home from `at`: goal points best first, back along the track
    /// from `ahead_m` down to `nearest_m` and across to earlier track
    /// points within `ahead_m` ([`crate::way_home::home_goals`]).
    pub fn home_goals(
        &self,
        at: [f64; 3],
        ahead_m: f64,
        nearest_m: f64,
        out: &mut impl FnMut([f64; 3]),
    ) {
        let Some(from) = self.trail.earliest_near(at, 2.0 * self.p.trail_spacing_m) else {
            out(self.home);
            return;
        };
        crate::way_home::home_goals(&self.trail, from, at, ahead_m, nearest_m, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn explores_until_nothing_is_left_then_returns_and_finishes_home() {
        let mut e = Explorer::new(ExplorerParams::default(), [0.0, 0.0, 0.2]);
        for k in 0..20 {
            e.observe(k as f64, [k as f64, 0.0, 0.2]);
        }
        e.query_result(false);
        e.query_result(true);
        assert_eq!(e.phase(), ExplorerPhase::Exploring);
        for _ in 0..3 {
            e.query_result(false);
        }
        assert_eq!(e.phase(), ExplorerPhase::Returning(ReturnReason::Explored));
        let mut goals = Vec::new();
        e.home_goals([19.0, 0.0, 0.2], 8.0, 2.0, &mut |g| goals.push(g));
        // From the earliest track point within 2 m (x = 17), 8 m back, then
        // each metre nearer, down to 2 m from the rover.
        assert!((goals[0][0] - 9.0).abs() < 1e-9, "{goals:?}");
        assert!(goals.iter().all(|g| g[0] <= 17.0), "{goals:?}");
        assert!(goals.len() >= 7, "{goals:?}");
        // A frontier seen on the way: exploring again, until it too is done.
        assert!(e.resume([19.0, 0.0]));
        assert_eq!(e.phase(), ExplorerPhase::Exploring);
        for _ in 0..3 {
            e.query_result(false);
        }
        assert_eq!(e.phase(), ExplorerPhase::Returning(ReturnReason::Explored));
        // Passing 0.3 m from home is not home yet; 0.2 m is.
        e.observe(100.0, [0.3, 0.0, 0.2]);
        assert_eq!(e.phase(), ExplorerPhase::Returning(ReturnReason::Explored));
        e.observe(101.0, [0.2, 0.0, 0.2]);
        assert_eq!(e.phase(), ExplorerPhase::Finished(ReturnReason::Explored));
        // Home is home.
        assert!(!e.resume([0.2, 0.0]));
        assert_eq!(e.phase(), ExplorerPhase::Finished(ReturnReason::Explored));
    }

    #[test]
    fn the_energy_budget_turns_the_rover_home_with_enough_left_to_get_there() {
        let p = ExplorerParams {
            energy_budget_wh: 100.0,
            ..ExplorerParams::default()
        };
        let mut e = Explorer::new(p, [0.0, 0.0, 0.2]);
        // Out along x at 1 Wh a metre: at x the way home costs 1.5 x Wh
        // more, so 2.5 x reaches 100 Wh at 40 m.
        for k in 0..=60 {
            e.set_energy_used(k as f64);
            e.observe(k as f64, [k as f64, 0.0, 0.2]);
            if e.phase() != ExplorerPhase::Exploring {
                break;
            }
        }
        assert_eq!(e.phase(), ExplorerPhase::Returning(ReturnReason::Energy));
        assert_eq!(e.driven_m(), 40.0);
        assert_eq!(e.way_home_m([40.0, 0.0, 0.2]), 40.0);
        // Something explorable on the way home does not turn it round.
        assert!(!e.resume([30.0, 0.0]));
        e.observe(100.0, [0.1, 0.0, 0.2]);
        assert_eq!(e.phase(), ExplorerPhase::Finished(ReturnReason::Energy));
        // Without a budget the same draw never sends it home.
        let mut e = Explorer::new(ExplorerParams::default(), [0.0, 0.0, 0.2]);
        for k in 0..=60 {
            e.set_energy_used(k as f64);
            e.observe(k as f64, [k as f64, 0.0, 0.2]);
        }
        assert_eq!(e.phase(), ExplorerPhase::Exploring);
    }

    #[test]
    fn passing_over_home_on_a_deck_above_it_is_not_home() {
        let mut e = Explorer::new(ExplorerParams::default(), [0.0, 0.0, 0.2]);
        for _ in 0..3 {
            e.query_result(false);
        }
        assert_eq!(e.phase(), ExplorerPhase::Returning(ReturnReason::Explored));
        // The garage's second deck, 6 m over home.
        e.observe(10.0, [0.1, 0.0, 6.2]);
        assert_eq!(e.phase(), ExplorerPhase::Returning(ReturnReason::Explored));
        // Down the ramps, on home's own floor.
        e.observe(20.0, [0.1, 0.0, 0.25]);
        assert_eq!(e.phase(), ExplorerPhase::Finished(ReturnReason::Explored));
    }

    #[test]
    fn exploring_resumed_in_vain_goes_home_and_does_not_resume_there_again() {
        let mut e = Explorer::new(ExplorerParams::default(), [0.0; 3]);
        for _ in 0..3 {
            e.query_result(false);
        }
        // Nothing reachable right after a resume: home again at once.
        assert!(e.resume([27.0, 4.0]));
        assert!(e.resumed_in_vain([27.0, 4.0]));
        assert_eq!(e.phase(), ExplorerPhase::Returning(ReturnReason::Explored));
        // The same patches from near there are not tried again ...
        assert!(!e.resume([30.0, 4.0]));
        assert_eq!(e.phase(), ExplorerPhase::Returning(ReturnReason::Explored));
        // ... but farther on they may be; and once a plan is driven, a
        // later dead end is an ordinary one (no return forced).
        assert!(e.resume([20.0, 4.0]));
        e.driven();
        assert!(!e.resumed_in_vain([15.0, 4.0]));
        assert_eq!(e.phase(), ExplorerPhase::Exploring);
        // Exploring that never was resumed is not cut short either.
        let mut fresh = Explorer::new(ExplorerParams::default(), [0.0; 3]);
        assert!(!fresh.resumed_in_vain([1.0, 0.0]));
        assert_eq!(fresh.phase(), ExplorerPhase::Exploring);
    }

    #[test]
    fn a_stranded_rover_ends_the_mission_where_it_stands_and_stays_stranded() {
        let mut e = Explorer::new(ExplorerParams::default(), [0.0; 3]);
        e.observe(1.0, [6.0, 0.0, 0.0]);
        e.strand();
        assert_eq!(e.phase(), ExplorerPhase::Stranded);
        // Nothing brings it back: neither a frontier, nor the time limit,
        // nor passing near home (it cannot move).
        assert!(!e.resume([6.0, 0.0]));
        e.query_result(false);
        e.observe(1.0e6, [0.0, 0.0, 0.0]);
        assert_eq!(e.phase(), ExplorerPhase::Stranded);
        // Home is home: a finished mission is not stranded afterwards.
        let mut home = Explorer::new(ExplorerParams::default(), [0.0; 3]);
        for _ in 0..3 {
            home.query_result(false);
        }
        home.observe(2.0, [0.1, 0.0, 0.0]);
        home.strand();
        assert_eq!(
            home.phase(),
            ExplorerPhase::Finished(ReturnReason::Explored)
        );
    }

    #[test]
    fn the_time_limit_sends_the_rover_home_and_rejections_are_bounded() {
        let mut e = Explorer::new(
            ExplorerParams {
                time_limit_s: 10.0,
                ..ExplorerParams::default()
            },
            [0.0; 3],
        );
        e.observe(11.0, [5.0, 0.0, 0.0]);
        assert_eq!(e.phase(), ExplorerPhase::Returning(ReturnReason::TimeLimit));
        assert!(!e.resume([5.0, 0.0]));
        assert_eq!(e.phase(), ExplorerPhase::Returning(ReturnReason::TimeLimit));
        for k in 0..100 {
            e.reject([k as f64, 0.0]);
        }
        assert_eq!(e.rejected().len(), MAX_REJECTED);
        assert_eq!(e.rejected()[0], [36.0, 0.0]);
    }
}
