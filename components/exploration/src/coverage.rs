//! The coverage map: the areas the rover has been near. Patches it covers
//! are not exploration candidates, so that a border of the map the LiDAR
//! cannot see past (a cliff's edge seen from above) is not tried forever.
//! A fixed bit grid around the start: its memory is taken once.

#[derive(Clone, Debug)]
pub struct CoverageMap {
    resolution: f64,
    /// Cell (0, 0)'s corner, m.
    origin: [f64; 2],
    side: usize,
    bits: Vec<u64>,
    covered: usize,
}

impl CoverageMap {
    /// A square of `extent_m` around `centre`, in cells of `resolution_m`.
    pub fn new(centre: [f64; 2], extent_m: f64, resolution_m: f64) -> Self {
        let side = (extent_m / resolution_m).ceil().max(1.0) as usize;
        let half = side as f64 * resolution_m / 2.0;
        CoverageMap {
            resolution: resolution_m,
            origin: [centre[0] - half, centre[1] - half],
            side,
            bits: vec![0; (side * side).div_ceil(64)],
            covered: 0,
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

    /// Mark every cell whose centre is within `radius_m` of (x, y).
    pub fn mark(&mut self, x: f64, y: f64, radius_m: f64) {
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

    /// Whether (x, y) is covered (outside the grid: no).
    pub fn covered(&self, x: f64, y: f64) -> bool {
        let (ix, iy) = self.cell(x, y);
        self.index(ix, iy)
            .is_some_and(|i| self.bits[i / 64] & (1 << (i % 64)) != 0)
    }

    /// Covered area, m^2.
    pub fn area_m2(&self) -> f64 {
        self.covered as f64 * self.resolution * self.resolution
    }

    pub fn memory_bytes(&self) -> usize {
        self.bits.len() * 8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marks_a_disc_and_counts_it_once() {
        let mut c = CoverageMap::new([0.0, 0.0], 20.0, 0.25);
        c.mark(1.0, 1.0, 2.0);
        assert!(c.covered(1.0, 1.0) && c.covered(2.7, 1.0) && !c.covered(3.5, 1.0));
        let a = c.area_m2();
        assert!((a - std::f64::consts::PI * 4.0).abs() < 1.0, "{a}");
        c.mark(1.0, 1.0, 2.0);
        assert_eq!(c.area_m2(), a);
        // Off the grid: never covered, never a panic.
        c.mark(100.0, 0.0, 2.0);
        assert!(!c.covered(100.0, 0.0));
    }
}
