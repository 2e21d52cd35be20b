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

mod hash;
pub mod marching_cubes;
pub mod mls;
pub mod tsdf;

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

#[cfg(test)]
mod tests {
    use super::floor_i32;

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
