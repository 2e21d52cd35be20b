//! A success rate's confidence interval and a sample's spread.

use serde::Serialize;

/// The normal quantile of a two-sided 95 % interval.
const Z95: f64 = 1.959_963_984_540_054;

/// Successes out of trials with Wilson's 95 % score interval.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Rate {
    pub passed: usize,
    pub n: usize,
    pub rate: f64,
    pub low: f64,
    pub high: f64,
}

/// Wilson's score interval, which stays within 0..1 and means something
/// at 0 of n and n of n (where the normal approximation collapses to a
/// point).
pub fn wilson(passed: usize, n: usize) -> Rate {
    if n == 0 {
        return Rate {
            passed,
            n,
            rate: 0.0,
            low: 0.0,
            high: 1.0,
        };
    }
    let (k, n_f) = (passed as f64, n as f64);
    let p = k / n_f;
    let z2 = Z95 * Z95;
    let denom = 1.0 + z2 / n_f;
    let centre = (p + z2 / (2.0 * n_f)) / denom;
    let half = Z95 * (p * (1.0 - p) / n_f + z2 / (4.0 * n_f * n_f)).sqrt() / denom;
    Rate {
        passed,
        n,
        rate: p,
        low: (centre - half).max(0.0),
        high: (centre + half).min(1.0),
    }
}

/// Median and the 10th and 90th percentiles (linear between order
/// statistics), over the values present.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Spread {
    pub n: usize,
    pub median: f64,
    pub p10: f64,
    pub p90: f64,
}

pub fn spread(values: &[f64]) -> Option<Spread> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(Spread {
        n: v.len(),
        median: quantile(&v, 0.5),
        p10: quantile(&v, 0.1),
        p90: quantile(&v, 0.9),
    })
}

/// The q-quantile of sorted values, interpolated.
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    let pos = q * (sorted.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a broken fixture fails the test where it breaks
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_a_hand_computation() {
        // 7 of 10: p = 0.7, z^2 = 3.8415; centre = (0.7 + 0.19207) / 1.38415
        // = 0.64449; half = 1.96 * sqrt(0.021 + 0.0096037) / 1.38415
        // = 0.24771; so 0.3968 .. 0.8922.
        let r = wilson(7, 10);
        assert!((r.rate - 0.7).abs() < 1e-12);
        assert!((r.low - 0.3968).abs() < 5e-4, "{r:?}");
        assert!((r.high - 0.8922).abs() < 5e-4, "{r:?}");
    }

    #[test]
    fn wilson_at_the_ends_is_not_a_point() {
        let none = wilson(0, 8);
        assert_eq!(none.low, 0.0);
        assert!(none.high > 0.3 && none.high < 0.4, "{none:?}");
        let all = wilson(8, 8);
        assert_eq!(all.high, 1.0);
        assert!(all.low > 0.6 && all.low < 0.7, "{all:?}");
        let empty = wilson(0, 0);
        assert_eq!((empty.low, empty.high), (0.0, 1.0));
    }

    #[test]
    fn spread_interpolates_between_order_statistics() {
        let s = spread(&[5.0, 1.0, 3.0, 2.0, 4.0, f64::NAN]).unwrap();
        assert_eq!(s.n, 5);
        assert_eq!(s.median, 3.0);
        assert!((s.p10 - 1.4).abs() < 1e-12);
        assert!((s.p90 - 4.6).abs() < 1e-12);
        assert!(spread(&[]).is_none());
    }
}
