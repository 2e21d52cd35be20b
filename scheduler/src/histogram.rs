//! A fixed-bucket, log-linear histogram of durations in nanoseconds.
//!
//! 16 sub-buckets per power of two give a relative error below 6.25 %, enough
//! to read p99 and p99.9 of execution times; the table has a fixed size, so
//! recording never allocates. The maximum is kept exactly.

const SUB_BITS: u32 = 4;
const SUB: u64 = 1 << SUB_BITS;
/// Values at or above 2^40 ns (about 18 minutes) share the last bucket.
const TOP_EXP: u32 = 40;
/// Number of buckets.
pub const BUCKETS: usize = ((TOP_EXP - SUB_BITS + 1) as usize) * SUB as usize;

#[derive(Clone, Debug)]
pub struct Histogram {
    counts: [u32; BUCKETS],
    total: u64,
    max_ns: u64,
}

impl Default for Histogram {
    fn default() -> Self {
        Self::new()
    }
}

impl Histogram {
    pub const fn new() -> Self {
        Histogram {
            counts: [0; BUCKETS],
            total: 0,
            max_ns: 0,
        }
    }

    #[inline]
    fn index(ns: u64) -> usize {
        if ns < SUB {
            return ns as usize;
        }
        let exp = 63 - ns.leading_zeros();
        if exp >= TOP_EXP {
            return BUCKETS - 1;
        }
        let sub = (ns >> (exp - SUB_BITS)) & (SUB - 1);
        ((exp - SUB_BITS + 1) as usize) * SUB as usize + sub as usize
    }

    /// Largest value that falls in bucket `i`.
    fn upper_bound(i: usize) -> u64 {
        let sub = SUB as usize;
        if i < sub {
            return i as u64;
        }
        if i == BUCKETS - 1 {
            return u64::MAX;
        }
        let exp = (i / sub) as u32 + SUB_BITS - 1;
        let s = (i % sub) as u64;
        let low = (1u64 << exp) + (s << (exp - SUB_BITS));
        low + (1u64 << (exp - SUB_BITS)) - 1
    }

    #[inline]
    pub fn record(&mut self, ns: u64) {
        let i = Self::index(ns);
        self.counts[i] = self.counts[i].saturating_add(1);
        self.total += 1;
        if ns > self.max_ns {
            self.max_ns = ns;
        }
    }

    pub fn count(&self) -> u64 {
        self.total
    }

    /// Add `other`'s records to these (runs measured apart, read as one).
    pub fn merge(&mut self, other: &Histogram) {
        for (c, o) in self.counts.iter_mut().zip(&other.counts) {
            *c = c.saturating_add(*o);
        }
        self.total += other.total;
        self.max_ns = self.max_ns.max(other.max_ns);
    }

    pub fn max_ns(&self) -> u64 {
        self.max_ns
    }

    /// The `q`-quantile (0 < q <= 1), as the upper bound of its bucket, never
    /// above the exact maximum. 0 when empty.
    pub fn quantile_ns(&self, q: f64) -> u64 {
        if self.total == 0 {
            return 0;
        }
        let rank = libm_ceil(q.clamp(0.0, 1.0) * self.total as f64).max(1.0) as u64;
        let mut seen = 0u64;
        for (i, &c) in self.counts.iter().enumerate() {
            seen += c as u64;
            if seen >= rank {
                return Self::upper_bound(i).min(self.max_ns);
            }
        }
        self.max_ns
    }
}

/// `ceil` without std (f64::ceil is not in core).
fn libm_ceil(x: f64) -> f64 {
    let t = x as u64 as f64;
    if t < x {
        t + 1.0
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_merge_reads_as_one_histogram_of_both() {
        let (mut a, mut b, mut both) = (Histogram::new(), Histogram::new(), Histogram::new());
        for v in 0..1000u64 {
            let (x, y) = (v * 7 % 5000, 3000 + v * 13 % 9000);
            a.record(x);
            b.record(y);
            both.record(x);
            both.record(y);
        }
        a.merge(&b);
        assert_eq!(a.count(), both.count());
        assert_eq!(a.max_ns(), both.max_ns());
        for q in [0.5, 0.9, 0.999] {
            assert_eq!(a.quantile_ns(q), both.quantile_ns(q));
        }
    }

    #[test]
    fn small_values_are_exact() {
        for v in 0..16 {
            assert_eq!(Histogram::upper_bound(Histogram::index(v)), v);
        }
    }

    #[test]
    fn buckets_bound_their_values_within_one_sixteenth() {
        let mut v = 16u64;
        while v < (1u64 << 39) {
            let ub = Histogram::upper_bound(Histogram::index(v));
            assert!(ub >= v, "{v} -> {ub}");
            assert!((ub - v) as f64 <= v as f64 / 16.0, "{v} -> {ub}");
            v = v * 17 / 16 + 1;
        }
    }

    #[test]
    fn quantiles_of_a_uniform_sample() {
        let mut h = Histogram::new();
        for v in 1..=10_000u64 {
            h.record(v * 1000);
        }
        let p50 = h.quantile_ns(0.5) as f64;
        let p99 = h.quantile_ns(0.99) as f64;
        assert!((p50 / 5_000_000.0 - 1.0).abs() < 0.07, "{p50}");
        assert!((p99 / 9_900_000.0 - 1.0).abs() < 0.07, "{p99}");
        assert_eq!(h.quantile_ns(1.0), 10_000_000);
        assert_eq!(h.max_ns(), 10_000_000);
        assert_eq!(h.count(), 10_000);
    }

    #[test]
    fn huge_values_do_not_overflow() {
        let mut h = Histogram::new();
        h.record(u64::MAX);
        assert_eq!(h.quantile_ns(0.5), u64::MAX);
    }
}
