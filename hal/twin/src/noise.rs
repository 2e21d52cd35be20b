//! Seeded noise that repeats bit for bit on any machine.

use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub struct Noise {
    rng: ChaCha8Rng,
}

impl Noise {
    /// `stream` separates independent sources seeded from one mission seed.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(stream);
        Noise { rng }
    }

    /// Uniform in [0, 1), from the top 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Approximately standard normal: the Irwin-Hall sum of 12 uniforms,
    /// exact arithmetic only (no libm), so it cannot differ between machines.
    pub fn gaussian(&mut self) -> f64 {
        let mut s = 0.0;
        for _ in 0..12 {
            s += self.uniform();
        }
        s - 6.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_stream() {
        let mut a = Noise::new(7, 1);
        let mut b = Noise::new(7, 1);
        let mut c = Noise::new(7, 2);
        let va: Vec<f64> = (0..10).map(|_| a.gaussian()).collect();
        let vb: Vec<f64> = (0..10).map(|_| b.gaussian()).collect();
        let vc: Vec<f64> = (0..10).map(|_| c.gaussian()).collect();
        assert_eq!(va, vb);
        assert_ne!(va, vc);
    }

    #[test]
    fn gaussian_moments() {
        let mut n = Noise::new(1, 0);
        let xs: Vec<f64> = (0..20_000).map(|_| n.gaussian()).collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / xs.len() as f64;
        assert!(mean.abs() < 0.03, "{mean}");
        assert!((var - 1.0).abs() < 0.05, "{var}");
    }
}
