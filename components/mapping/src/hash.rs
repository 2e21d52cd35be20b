//! The deterministic hash of the open-addressing tables: the same keys land
//! in the same slots on every run and machine (no random seed, unlike
//! `std::collections::HashMap`).

/// SplitMix64's finaliser: every input bit reaches every output bit, so
/// neighbouring cells or blocks spread over the table.
#[inline(always)]
pub(crate) fn mix64(mut x: u64) -> u64 {
    x ^= x >> 30;
    x = x.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x ^= x >> 27;
    x = x.wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// Table size for `capacity` entries: a power of two at least twice the
/// capacity, so the load stays at or below one half and linear probing
/// always meets an empty slot quickly.
pub(crate) fn table_size(capacity: usize) -> usize {
    capacity.saturating_mul(2).max(2).next_power_of_two()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_size_keeps_half_load() {
        assert_eq!(table_size(0), 2);
        assert_eq!(table_size(1), 2);
        assert_eq!(table_size(3), 8);
        assert_eq!(table_size(4), 8);
        assert_eq!(table_size(1000), 2048);
    }

    #[test]
    fn mix_is_fixed() {
        // Pinned: a change here changes every map's layout.
        assert_eq!(mix64(0), 0);
        assert_ne!(mix64(1), mix64(2));
    }
}
