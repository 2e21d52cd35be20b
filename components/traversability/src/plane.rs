//! The support plane `z = a x + b y + c` of a footprint: RANSAC over
//! triples (the first best consensus wins), then least squares over its
//! inliers. The random triples come from a generator seeded by the cell,
//! so the same map gives the same planes.

/// A fitted plane and its support.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub inliers: usize,
}

impl Plane {
    pub fn z_at(&self, x: f64, y: f64) -> f64 {
        self.a * x + self.b * y + self.c
    }

    /// Angle between the plane and the horizontal, degrees.
    pub fn slope_deg(&self) -> f64 {
        self.a.hypot(self.b).atan().to_degrees()
    }

    /// Unit normal, pointing up.
    pub fn normal(&self) -> [f64; 3] {
        let n = (self.a * self.a + self.b * self.b + 1.0).sqrt();
        [-self.a / n, -self.b / n, 1.0 / n]
    }
}

/// SplitMix64: small, fast and the same everywhere.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// The plane through three points, if they are not collinear in x, y.
fn through(p: [f64; 3], q: [f64; 3], r: [f64; 3]) -> Option<(f64, f64, f64)> {
    let (ux, uy, uz) = (q[0] - p[0], q[1] - p[1], q[2] - p[2]);
    let (vx, vy, vz) = (r[0] - p[0], r[1] - p[1], r[2] - p[2]);
    let det = ux * vy - uy * vx;
    if det.abs() < 1e-9 {
        return None;
    }
    let a = (uz * vy - uy * vz) / det;
    let b = (ux * vz - uz * vx) / det;
    Some((a, b, p[2] - a * p[0] - b * p[1]))
}

/// Least squares `z = a x + b y + c` over the points within `tol` of the
/// plane `(a, b, c)`, coordinates taken relative to `o` for conditioning.
fn refine(points: &[[f64; 3]], abc: (f64, f64, f64), tol: f64, o: [f64; 2]) -> Option<Plane> {
    let (mut sxx, mut sxy, mut syy, mut sx, mut sy, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut sxz, mut syz, mut sz) = (0.0, 0.0, 0.0);
    for p in points {
        if (p[2] - (abc.0 * p[0] + abc.1 * p[1] + abc.2)).abs() > tol {
            continue;
        }
        let (x, y, z) = (p[0] - o[0], p[1] - o[1], p[2]);
        sxx += x * x;
        sxy += x * y;
        syy += y * y;
        sx += x;
        sy += y;
        sxz += x * z;
        syz += y * z;
        sz += z;
        n += 1.0;
    }
    // Solve [sxx sxy sx; sxy syy sy; sx sy n] [a b c'] = [sxz syz sz].
    let m = [[sxx, sxy, sx], [sxy, syy, sy], [sx, sy, n]];
    let rhs = [sxz, syz, sz];
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    if d.abs() < 1e-12 {
        return None;
    }
    let col = |k: usize| {
        let mut c = m;
        for i in 0..3 {
            c[i][k] = rhs[i];
        }
        det(&c) / d
    };
    let (a, b, c0) = (col(0), col(1), col(2));
    Some(Plane {
        a,
        b,
        c: c0 - a * o[0] - b * o[1],
        inliers: n as usize,
    })
}

/// The inliers of plane `abc` among `points` if they are more than
/// `to_beat`. The count stops once the points left cannot make up the
/// difference: on a footprint of flat floor the first triple takes nearly
/// every point, and most later ones fall behind within a few points.
fn consensus(
    points: &[[f64; 3]],
    abc: (f64, f64, f64),
    tol: f64,
    to_beat: Option<usize>,
) -> Option<usize> {
    let mut count = 0;
    for (k, p) in points.iter().enumerate() {
        count += ((p[2] - (abc.0 * p[0] + abc.1 * p[1] + abc.2)).abs() <= tol) as usize;
        if to_beat.is_some_and(|b| count + (points.len() - 1 - k) <= b) {
            return None;
        }
    }
    Some(count)
}

/// The support plane of `points` (x, y, z), or `None` when no plane has
/// `min_inliers` within `tol`.
pub fn fit(
    points: &[[f64; 3]],
    seed: u64,
    iterations: usize,
    tol: f64,
    min_inliers: usize,
) -> Option<Plane> {
    let n = points.len();
    if n < min_inliers.max(3) {
        return None;
    }
    let mut rng = SplitMix(seed);
    let mut best: Option<((f64, f64, f64), usize)> = None;
    for _ in 0..iterations {
        let (i, j, k) = (rng.below(n), rng.below(n), rng.below(n));
        let Some(abc) = through(points[i], points[j], points[k]) else {
            continue;
        };
        let Some(count) = consensus(points, abc, tol, best.map(|(_, c)| c)) else {
            continue;
        };
        best = Some((abc, count));
    }
    let (abc, count) = best?;
    if count < min_inliers {
        return None;
    }
    let o = [points[0][0], points[0][1]];
    refine(points, abc, tol, o).filter(|p| p.inliers >= min_inliers)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_consensus_stops_early_only_for_triples_that_cannot_win() {
        let mut rng = SplitMix(3);
        let mut unit = || (rng.next() >> 11) as f64 / (1u64 << 53) as f64;
        for round in 0..200 {
            let pts: Vec<[f64; 3]> = (0..49)
                .map(|k| {
                    let (x, y) = ((k % 7) as f64 * 0.1, (k / 7) as f64 * 0.1);
                    let rock = if unit() < 0.3 { 0.2 * unit() } else { 0.0 };
                    [x, y, 0.1 * x + 0.01 * unit() + rock]
                })
                .collect();
            let (abc, tol) = ((0.1, 0.0, 0.005), 0.01);
            let full = pts
                .iter()
                .filter(|p| (p[2] - (abc.0 * p[0] + abc.1 * p[1] + abc.2)).abs() <= tol)
                .count();
            for to_beat in [None, Some(0), Some(full - 1), Some(full), Some(49)] {
                let want = to_beat.is_none_or(|b| full > b).then_some(full);
                assert_eq!(
                    consensus(&pts, abc, tol, to_beat),
                    want,
                    "{round} {to_beat:?}"
                );
            }
        }
    }

    #[test]
    fn a_tilted_plane_is_found_despite_a_rock() {
        let mut pts = Vec::new();
        for i in 0..7 {
            for j in 0..7 {
                let (x, y) = (i as f64 * 0.1, j as f64 * 0.1);
                pts.push([x, y, 0.2 * x - 0.1 * y + 1.0]);
            }
        }
        pts[10][2] += 0.3;
        pts[11][2] += 0.3;
        let p = fit(&pts, 7, 24, 0.02, 5).unwrap_or_else(|| panic!("no plane"));
        assert_eq!(p.inliers, 47);
        assert!((p.a - 0.2).abs() < 1e-9 && (p.b + 0.1).abs() < 1e-9 && (p.c - 1.0).abs() < 1e-9);
        assert!((p.slope_deg() - 0.05f64.sqrt().atan().to_degrees()).abs() < 1e-9);
        assert_eq!(fit(&pts[..4], 7, 24, 0.02, 5), None, "too few points");
    }
}
