//! The way home: the rover's own track, kept a point every metre. Going
//! home follows it backwards from the earliest point near the rover, so a
//! loop driven on the way out is cut short on the way back.

/// Points of the track, m apart.
#[derive(Clone, Debug)]
pub struct Trail {
    spacing_m: f64,
    /// The spacing asked for (thinning doubles `spacing_m`).
    base_spacing_m: f64,
    points: Vec<[f64; 3]>,
    /// The track's length from home to each point, m (across).
    along_m: Vec<f64>,
    capacity: usize,
}

impl Trail {
    /// Room for `capacity` points (the track's length in `spacing_m`).
    pub fn new(capacity: usize, spacing_m: f64) -> Self {
        Trail {
            spacing_m,
            base_spacing_m: spacing_m,
            points: Vec::with_capacity(capacity),
            along_m: Vec::with_capacity(capacity),
            capacity,
        }
    }

    /// Forget the track (the spacing set at construction stays).
    pub fn clear(&mut self) {
        self.points.clear();
        self.along_m.clear();
        self.spacing_m = self.base_spacing_m;
    }

    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// Add the rover's position when it is a spacing from the last point.
    /// When full, every other point is dropped and the spacing doubles, so
    /// the track still reaches home.
    pub fn record(&mut self, p: [f64; 3]) {
        if let Some(l) = self.points.last() {
            if (p[0] - l[0]).hypot(p[1] - l[1]) < self.spacing_m {
                return;
            }
        }
        if self.points.len() == self.capacity {
            let mut k = 0;
            for i in (0..self.points.len()).step_by(2) {
                self.points[k] = self.points[i];
                k += 1;
            }
            self.points.truncate(k);
            self.spacing_m *= 2.0;
            self.along_m.clear();
            for i in 0..self.points.len() {
                let step = i
                    .checked_sub(1)
                    .map_or(0.0, |j| across(self.points[j], self.points[i]));
                let before = self.along_m.last().copied().unwrap_or(0.0);
                self.along_m.push(before + step);
            }
        }
        let step = self.points.last().map_or(0.0, |&l| across(l, p));
        let before = self.along_m.last().copied().unwrap_or(0.0);
        self.along_m.push(before + step);
        self.points.push(p);
    }

    /// The earliest point within `reach_m` of `at` across and within
    /// [`LEVEL_M`] of its height (the nearest in space when none is that
    /// near): on a level over the track, the track below is not near.
    pub fn earliest_near(&self, at: [f64; 3], reach_m: f64) -> Option<usize> {
        self.points
            .iter()
            .position(|p| near(p, at, reach_m))
            .or_else(|| self.nearest(at))
    }

    /// The most recent point within `reach_m` of `at` across and within
    /// [`LEVEL_M`] of its height (the nearest in space when none is that
    /// near). A way driven without planning starts here: the rover came
    /// from it, whereas an earlier point beside it (on a ramp passing
    /// over the rover's floor) may be out of its reach.
    pub fn latest_near(&self, at: [f64; 3], reach_m: f64) -> Option<usize> {
        self.points
            .iter()
            .rposition(|p| near(p, at, reach_m))
            .or_else(|| self.nearest(at))
    }

    fn nearest(&self, at: [f64; 3]) -> Option<usize> {
        let dist = |p: &[f64; 3]| (p[0] - at[0]).hypot(p[1] - at[1]).hypot(p[2] - at[2]);
        (0..self.points.len()).min_by(|&a, &b| {
            dist(&self.points[a])
                .total_cmp(&dist(&self.points[b]))
                .then(a.cmp(&b))
        })
    }

    /// Walking home from point `from`: the point `ahead_m` farther back
    /// along the track (home itself at the end).
    pub fn back_from(&self, from: usize, ahead_m: f64) -> Option<[f64; 3]> {
        let mut i = from.min(self.points.len().checked_sub(1)?);
        let mut left = ahead_m;
        while i > 0 {
            let (a, b) = (self.points[i], self.points[i - 1]);
            let d = (a[0] - b[0]).hypot(a[1] - b[1]);
            if d >= left {
                let f = left / d;
                return Some([
                    a[0] + f * (b[0] - a[0]),
                    a[1] + f * (b[1] - a[1]),
                    a[2] + f * (b[2] - a[2]),
                ]);
            }
            left -= d;
            i -= 1;
        }
        Some(self.points[0])
    }

    /// The length of the track from point `from` back to home, m (across,
    /// as [`Self::back_from`] walks it).
    pub fn length_back_from(&self, from: usize) -> f64 {
        self.along_m
            .get(from)
            .or(self.along_m.last())
            .copied()
            .unwrap_or(0.0)
    }
}

/// Track points more than this over or under the rover are on another
/// level (a garage's floor under its deck), m.
pub const LEVEL_M: f64 = 1.0;

/// The distance from `a` to `b` across, m.
fn across(a: [f64; 3], b: [f64; 3]) -> f64 {
    (b[0] - a[0]).hypot(b[1] - a[1])
}

/// Track point `p` lies within `reach_m` of `at` across, on its level.
fn near(p: &[f64; 3], at: [f64; 3], reach_m: f64) -> bool {
    (p[0] - at[0]).hypot(p[1] - at[1]) <= reach_m && (p[2] - at[2]).abs() <= LEVEL_M
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn going_home_cuts_a_loop_short_and_ends_at_home() {
        let mut t = Trail::new(1000, 1.0);
        // Out 10 m, round a loop and back past x = 5.
        for k in 0..=10 {
            t.record([k as f64, 0.0, 0.0]);
        }
        for k in 0..=5 {
            t.record([10.0 - k as f64, 3.0, 0.0]);
        }
        let from = t.earliest_near([5.0, 2.5, 0.0], 2.6).expect("near");
        assert_eq!(t.points()[from], [5.0, 0.0, 0.0]);
        let g = t.back_from(from, 2.5).expect("goal");
        assert!((g[0] - 2.5).abs() < 1e-9 && g[1] == 0.0, "{g:?}");
        assert_eq!(t.back_from(from, 50.0), Some([0.0, 0.0, 0.0]));
        // The way home from there is 5 m, not the 18 m driven.
        assert_eq!(t.length_back_from(from), 5.0);
        assert_eq!(t.length_back_from(t.points().len() - 1), 18.0);
        assert_eq!(t.length_back_from(0), 0.0);
    }

    #[test]
    fn a_full_trail_thins_out_and_keeps_home() {
        let mut t = Trail::new(8, 1.0);
        for k in 0..40 {
            t.record([k as f64, 0.0, 0.0]);
        }
        assert!(t.points().len() <= 8);
        assert_eq!(t.points()[0], [0.0, 0.0, 0.0]);
        assert!(t.points().last().is_some_and(|p| p[0] >= 32.0));
    }

    #[test]
    fn the_track_on_the_level_below_is_not_near() {
        let mut t = Trail::new(1000, 1.0);
        // Along level 0, up a ramp to 3 m, back over the start on level 1.
        for k in 0..=10 {
            t.record([k as f64, 0.0, 0.0]);
        }
        for k in 1..=12 {
            t.record([10.0, k as f64, 0.25 * k as f64]);
        }
        for k in 1..=10 {
            t.record([10.0 - k as f64, 12.0, 3.0]);
        }
        let over_start = t.earliest_near([0.0, 12.0, 3.0], 2.0).expect("near");
        assert_eq!(t.points()[over_start][2], 3.0);
        // On level 0 the earliest point is the start.
        assert_eq!(t.earliest_near([0.5, 0.0, 0.0], 2.0), Some(0));
    }

    #[test]
    fn a_blind_retrace_starts_where_the_rover_came_from_not_on_a_ramp_beside_it() {
        let mut t = Trail::new(1000, 1.0);
        // Up a ramp along y = 0 to 0.75 m and back down it, then along the
        // floor beside the ramp (y = 1.5) under its higher part.
        for k in 0..=3 {
            t.record([k as f64, 0.0, 0.25 * k as f64]);
        }
        for k in (0..3).rev() {
            t.record([k as f64 + 0.01, 0.0, 0.25 * k as f64]);
        }
        for k in 0..=3 {
            t.record([k as f64, 1.5, 0.0]);
        }
        let at = [3.0, 1.5, 0.0];
        // Going home may cut across (it is planned and simulated first)...
        let early = t.earliest_near(at, 2.0).expect("near");
        assert!(t.points()[early][1] == 0.0, "{:?}", t.points()[early]);
        // ...a blind retrace starts on the floor the rover drove.
        let late = t.latest_near(at, 2.0).expect("near");
        assert_eq!(t.points()[late], [3.0, 1.5, 0.0]);
        // Far from every point: the nearest.
        assert_eq!(
            t.latest_near([50.0, 1.5, 0.0], 2.0),
            Some(t.points().len() - 1)
        );
    }
}
