//! The coverage map: the areas the rover has been near. Patches it covers
//! are not exploration candidates, so that a border of the map the LiDAR
//! cannot see past (a cliff's edge seen from above) is not tried forever.
//! A fixed bit grid around the start: its memory is taken once.
//!
//! Heights are kept too, coarsely: each metre cell holds the lowest and
//! highest the rover stood where it marked it, and a point is covered only
//! within `LEVEL_BAND_M` of that span. In a garage, driving under a ramp
//! must not cover the ramp's upper part, nor level 0 cover level 1.

#[derive(Clone, Debug)]
pub struct CoverageMap {
    resolution: f64,
    /// Cell (0, 0)'s corner, m.
    origin: [f64; 2],
    side: usize,
    bits: Vec<u64>,
    covered: usize,
    /// Per `LEVEL_CELL_M` cell: the lowest and highest rover height that
    /// marked it, cm (empty: low > high).
    levels: Vec<(i16, i16)>,
    level_side: usize,
}

/// Side of a height cell, m.
const LEVEL_CELL_M: f64 = 1.0;
/// A point this far over or under the heights the rover marked it from is
/// on another level: not covered, m.
pub const LEVEL_BAND_M: f64 = 1.5;
/// Over the heights the rover marked it from, a point is covered only this
/// far up, m: a cliff's edge is below the rover, and ground up a slope is
/// seen better from nearer. (In the garage, a rover 2 m short of a ramp's
/// top found no candidate and never went up, likely because its marks
/// covered the next level's edge 0.5 m over it, which the LiDAR sees from
/// the ramp only at grazing angles.)
pub const COVERED_ABOVE_M: f64 = 0.4;

impl CoverageMap {
    /// A square of `extent_m` around `centre`, in cells of `resolution_m`.
    pub fn new(centre: [f64; 2], extent_m: f64, resolution_m: f64) -> Self {
        let side = (extent_m / resolution_m).ceil().max(1.0) as usize;
        let half = side as f64 * resolution_m / 2.0;
        let level_side = (side as f64 * resolution_m / LEVEL_CELL_M).ceil().max(1.0) as usize;
        CoverageMap {
            resolution: resolution_m,
            origin: [centre[0] - half, centre[1] - half],
            side,
            bits: vec![0; (side * side).div_ceil(64)],
            covered: 0,
            levels: vec![(i16::MAX, i16::MIN); level_side * level_side],
            level_side,
        }
    }

    fn index(&self, ix: i64, iy: i64) -> Option<usize> {
        let s = self.side as i64;
        (ix >= 0 && iy >= 0 && ix < s && iy < s).then(|| (iy * s + ix) as usize)
    }

    fn cell(&self, x: f64, y: f64) -> (i64, i64) {
        (
            ((x - self.origin[0]) / self.resolution).floor() as i64,
            ((y - self.origin[1]) / self.resolution).floor() as i64,
        )
    }

    fn level_index(&self, x: f64, y: f64) -> Option<usize> {
        let ix = ((x - self.origin[0]) / LEVEL_CELL_M).floor() as i64;
        let iy = ((y - self.origin[1]) / LEVEL_CELL_M).floor() as i64;
        let s = self.level_side as i64;
        (ix >= 0 && iy >= 0 && ix < s && iy < s).then(|| (iy * s + ix) as usize)
    }

    /// Mark every cell whose centre is within `radius_m` of (x, y), seen
    /// by the rover at height `z`.
    pub fn mark(&mut self, x: f64, y: f64, z: f64, radius_m: f64) {
        let zc = (z * 100.0)
            .round()
            .clamp(i16::MIN as f64 + 1.0, i16::MAX as f64 - 1.0) as i16;
        let reach = (radius_m / LEVEL_CELL_M).ceil() as i64;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let (px, py) = (x + dx as f64 * LEVEL_CELL_M, y + dy as f64 * LEVEL_CELL_M);
                if let Some(i) = self.level_index(px, py) {
                    let (lo, hi) = self.levels[i];
                    self.levels[i] = (lo.min(zc), hi.max(zc));
                }
            }
        }
        let (cx, cy) = self.cell(x, y);
        let r = (radius_m / self.resolution).ceil() as i64;
        for iy in cy - r..=cy + r {
            for ix in cx - r..=cx + r {
                let Some(i) = self.index(ix, iy) else {
                    continue;
                };
                let px = self.origin[0] + (ix as f64 + 0.5) * self.resolution;
                let py = self.origin[1] + (iy as f64 + 0.5) * self.resolution;
                if (px - x).powi(2) + (py - y).powi(2) > radius_m * radius_m {
                    continue;
                }
                let (w, b) = (i / 64, 1u64 << (i % 64));
                if self.bits[w] & b == 0 {
                    self.bits[w] |= b;
                    self.covered += 1;
                }
            }
        }
    }

    /// Whether (x, y) at height `z` is covered (outside the grid: no):
    /// from `LEVEL_BAND_M` under the heights the rover marked it from to
    /// `COVERED_ABOVE_M` over them.
    pub fn covered(&self, x: f64, y: f64, z: f64) -> bool {
        self.within(x, y, z, COVERED_ABOVE_M)
    }

    /// Whether (x, y) was marked from heights whose span, widened by
    /// `LEVEL_BAND_M` under it and `above_m` over it, holds `z`.
    fn within(&self, x: f64, y: f64, z: f64, above_m: f64) -> bool {
        self.marked(x, y)
            && self.level_index(x, y).is_some_and(|i| {
                let (lo, hi) = self.levels[i];
                let zc = z * 100.0;
                lo <= hi
                    && zc >= lo as f64 - LEVEL_BAND_M * 100.0
                    && zc <= hi as f64 + above_m * 100.0
            })
    }

    /// Whether the rover has been near (x, y) but only on another level:
    /// `z` lies more than `LEVEL_BAND_M` over or under the heights it
    /// marked the place from (a ramp's upper part over the floor driven
    /// under it).
    pub fn level_apart(&self, x: f64, y: f64, z: f64) -> bool {
        self.marked(x, y) && !self.within(x, y, z, LEVEL_BAND_M)
    }

    /// Whether the rover has been near (x, y) as high as `z` or higher
    /// (its pose's height, which rides some 0.2 m over the ground): a
    /// crest it stood on or over is no longer one to look over.
    pub fn stood_as_high(&self, x: f64, y: f64, z: f64) -> bool {
        self.marked(x, y)
            && self.level_index(x, y).is_some_and(|i| {
                let (lo, hi) = self.levels[i];
                lo <= hi && hi as f64 >= z * 100.0
            })
    }

    /// Whether (x, y) lies near the rover's track, at any height.
    fn marked(&self, x: f64, y: f64) -> bool {
        let (ix, iy) = self.cell(x, y);
        self.index(ix, iy)
            .is_some_and(|i| self.bits[i / 64] & (1 << (i % 64)) != 0)
    }

    /// Covered area, m^2.
    pub fn area_m2(&self) -> f64 {
        self.covered as f64 * self.resolution * self.resolution
    }

    pub fn memory_bytes(&self) -> usize {
        self.bits.len() * 8 + self.levels.len() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marks_a_disc_and_counts_it_once() {
        let mut c = CoverageMap::new([0.0, 0.0], 20.0, 0.25);
        c.mark(1.0, 1.0, 0.2, 2.0);
        assert!(c.covered(1.0, 1.0, 0.0) && c.covered(2.7, 1.0, 0.0) && !c.covered(3.5, 1.0, 0.0));
        let a = c.area_m2();
        assert!((a - std::f64::consts::PI * 4.0).abs() < 1.0, "{a}");
        c.mark(1.0, 1.0, 0.2, 2.0);
        assert_eq!(c.area_m2(), a);
        // Off the grid: never covered, never a panic.
        c.mark(100.0, 0.0, 0.2, 2.0);
        assert!(!c.covered(100.0, 0.0, 0.0));
    }

    #[test]
    fn a_level_over_the_track_is_not_covered_until_driven() {
        // Driven under a ramp or a slab 3 m up: the ground up there is not
        // covered, the ground the rover drove is.
        let mut c = CoverageMap::new([0.0, 0.0], 20.0, 0.25);
        c.mark(1.0, 1.0, 0.2, 2.0);
        assert!(c.covered(1.5, 1.0, 0.0) && c.covered(1.5, 1.0, 0.5));
        assert!(!c.covered(1.5, 1.0, 3.0));
        assert!(c.level_apart(1.5, 1.0, 3.0) && !c.level_apart(1.5, 1.0, 0.0));
        assert!(
            !c.level_apart(8.0, 1.0, 3.0),
            "never near: not a level apart"
        );
        c.mark(1.0, 1.0, 3.2, 2.0);
        assert!(!c.level_apart(1.5, 1.0, 3.0));
        assert!(c.covered(1.5, 1.0, 3.0) && c.covered(1.5, 1.0, 0.0));
    }

    #[test]
    fn ground_up_a_slope_is_covered_only_near_the_rovers_height() {
        // On a ramp at 5.3 m, 2 m short of the next level (6 m): the level's
        // edge is left to explore, the ramp down behind and a drop's foot
        // 1.4 m under the rover are covered; neither is a level apart.
        let mut c = CoverageMap::new([0.0, 0.0], 20.0, 0.25);
        c.mark(0.0, 0.0, 5.3, 3.0);
        assert!(!c.covered(2.0, 0.0, 6.0) && !c.level_apart(2.0, 0.0, 6.0));
        assert!(c.covered(-2.0, 0.0, 4.6) && c.covered(2.0, 0.0, 5.6));
        assert!(c.covered(2.0, 0.0, 3.9) && !c.level_apart(2.0, 0.0, 3.9));
        // Once the rover stands up there, it is covered.
        c.mark(2.0, 0.0, 6.1, 3.0);
        assert!(c.covered(2.0, 0.0, 6.0));
    }

    #[test]
    fn a_crest_is_stood_as_high_once_the_rover_was_up_there() {
        let mut c = CoverageMap::new([0.0, 0.0], 20.0, 0.25);
        assert!(!c.stood_as_high(1.0, 0.0, 5.8), "never near");
        c.mark(0.0, 0.0, 5.57, 3.0);
        assert!(!c.stood_as_high(1.5, 0.0, 5.8));
        assert!(c.stood_as_high(1.5, 0.0, 5.5));
        c.mark(1.5, 0.0, 5.99, 3.0);
        assert!(c.stood_as_high(1.5, 0.0, 5.8));
        assert!(!c.stood_as_high(6.0, 0.0, 5.8), "out of reach of the marks");
    }
}
