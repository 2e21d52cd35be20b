//! Seeded value noise from integer hashing: the same numbers on every
//! machine (no platform maths beyond IEEE arithmetic).

/// SplitMix64 of a seed and two lattice coordinates, as a value in [-1, 1].
pub fn lattice(seed: u64, i: i64, j: i64) -> f64 {
    let mut z = seed
        .wrapping_add((i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
        .wrapping_add((j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

fn smooth(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

/// Smooth 1-D noise in [-1, 1] with features `scale` apart.
pub fn noise1(seed: u64, x: f64, scale: f64) -> f64 {
    let u = x / scale;
    let i = libm::floor(u);
    let t = smooth(u - i);
    let i = i as i64;
    lattice(seed, i, 0) * (1.0 - t) + lattice(seed, i + 1, 0) * t
}

/// Smooth 2-D noise in [-1, 1].
pub fn noise2(seed: u64, x: f64, y: f64, sx: f64, sy: f64) -> f64 {
    let (u, v) = (x / sx, y / sy);
    let (i, j) = (libm::floor(u), libm::floor(v));
    let (tu, tv) = (smooth(u - i), smooth(v - j));
    let (i, j) = (i as i64, j as i64);
    let a = lattice(seed, i, j) * (1.0 - tu) + lattice(seed, i + 1, j) * tu;
    let b = lattice(seed, i, j + 1) * (1.0 - tu) + lattice(seed, i + 1, j + 1) * tu;
    a * (1.0 - tv) + b * tv
}

/// Uniform in [0, 1) from a seed and an index.
pub fn uniform(seed: u64, k: i64) -> f64 {
    0.5 * (lattice(seed, k, 0x5EED) + 1.0)
}
