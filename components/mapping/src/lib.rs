//! Maps built from LiDAR keyframes (paper section 2.1): a multi-level
//! surface map for the planner and a TSDF volume meshed on demand for the
//! internal simulator.
//!
//! - [`mls`]: a multi-level surface map (Triebel, Pfaff, Burgard 2006): a
//!   2D grid of cells, each holding a few horizontal or vertical surface
//!   patches, in a hash table of fixed capacity.
//! - [`tsdf`]: a truncated signed distance volume (Curless and Levoy 1996)
//!   of 8x8x8 voxel blocks from a fixed pool, integrated along rays by a 3D
//!   DDA (Amanatides and Woo 1987).
//! - [`marching_cubes`]: the zero level set of the TSDF as a triangle mesh
//!   (Lorensen and Cline 1987), with welded vertices, and a PLY writer.
//!
//! Every structure takes its memory at construction: inserting a scan or
//! integrating one allocates nothing, a full table drops and counts what
//! does not fit, and bad points (NaN, infinite, out of range) are skipped
//! and counted. The same inputs give bit-identical maps (fixed hashes,
//! fixed orders, one thread, no transcendental functions).

pub mod builder;
mod hash;
pub mod keyframes;
pub mod marching_cubes;
pub mod mls;
pub mod surface_maps;
pub mod tsdf;

pub use builder::{BuilderParams, MapBuilder, MapsCounters};
pub use keyframes::KeyframeClouds;
pub use surface_maps::SurfaceMaps;

/// A parameter that makes a map impossible to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamsError {
    /// A length (resolution, voxel size, gap, ...) that is not finite and
    /// positive, named by its parameter.
    NotPositive(&'static str),
    /// A length or noise that is not finite and non-negative, named by its
    /// parameter.
    Negative(&'static str),
    /// A setting beyond what the structure supports, named by its
    /// parameter.
    TooLarge(&'static str),
}

impl std::fmt::Display for ParamsError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamsError::NotPositive(name) => write!(f, "{name} must be finite and positive"),
            ParamsError::Negative(name) => write!(f, "{name} must be finite and non-negative"),
            ParamsError::TooLarge(name) => write!(f, "{name} is too large"),
        }
    }
}

impl std::error::Error for ParamsError {}

/// A buffer of `n` copies of `value`, every page of it written now: the
/// system may hand out zero-filled memory lazily, and the first touch of
/// each page would then cost a page fault in the periodic work instead of
/// at start-up. (`black_box` keeps the writes from being optimised out.)
pub(crate) fn resident_buffer<T: Copy>(n: usize, value: T) -> Vec<T> {
    let mut v = vec![value; n];
    let per_page = (4096 / std::mem::size_of::<T>().max(1)).max(1);
    for chunk in v.chunks_mut(per_page) {
        chunk[0] = std::hint::black_box(value);
    }
    v
}

/// Asks the processor to bring the cache line holding `r` closer: a hint
/// without effect on the results (a no-op off x86-64).
#[inline(always)]
pub(crate) fn prefetch<T>(r: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: SSE is part of every x86-64 target, and a prefetch never
        // faults (the address is even valid: it comes from a reference).
        unsafe { _mm_prefetch::<_MM_HINT_T0>((r as *const T).cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = r;
}

/// Largest integer not above `x`, saturating to the `i32` range (NaN gives
/// 0). The callers reject coordinates far from the range first; this avoids
/// the library call `f64::floor` compiles to on baseline x86-64.
#[inline(always)]
pub(crate) fn floor_i32(x: f64) -> i32 {
    // `as` saturates (and maps NaN to 0); the correction below must too.
    let i = x as i32;
    if (i as f64) > x {
        // Saturated at i32::MIN when x is below it.
        i.saturating_sub(1)
    } else {
        i
    }
}

/// Largest integer not above `x`, for `|x| < 2^31` only (callers check):
/// adding 1.5 * 2^52 rounds `x` to the nearest integer, which lands in the
/// low bits of the sum; one step down if that was above `x`. Exact, a few
/// instructions, no branch.
#[inline(always)]
pub(crate) fn floor_small(x: f64) -> i32 {
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let t = x + ROUND;
    let nearest = t - ROUND;
    (t.to_bits() as i32).wrapping_sub((nearest > x) as i32)
}

#[cfg(test)]
mod tests {
    use super::{floor_i32, floor_small};

    #[test]
    fn floor_small_is_floor() {
        let mut x = -5.0f64;
        while x <= 5.0 {
            for v in [x, x.next_up(), x.next_down()] {
                assert_eq!(floor_small(v), v.floor() as i32, "{v}");
            }
            x += 0.125;
        }
        for v in [
            -0.0,
            0.0,
            0.49999999999999994,
            -0.49999999999999994,
            1_073_741_823.9,
            -1_073_741_823.9,
            2_147_483_647.5,
            -2_147_483_647.5,
        ] {
            assert_eq!(floor_small(v), v.floor() as i32, "{v}");
        }
    }

    #[test]
    fn floor_saturates_and_rounds_down() {
        assert_eq!(floor_i32(-0.5), -1);
        assert_eq!(floor_i32(-1.0), -1);
        assert_eq!(floor_i32(2.99), 2);
        assert_eq!(floor_i32(-1e300), i32::MIN);
        assert_eq!(floor_i32(1e300), i32::MAX);
        assert_eq!(floor_i32(f64::NAN), 0);
    }
}
