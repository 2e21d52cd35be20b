//! The block pool: `max_blocks` blocks of 8x8x8 voxels taken at
//! construction, found through an open-addressing hash of their integer
//! block coordinates.

use crate::hash::{mix64, table_size};
use crate::resident_buffer;

/// Voxels along a block's side.
pub const BLOCK_SIDE: usize = 8;
/// Voxels in a block.
pub const BLOCK_VOXELS: usize = BLOCK_SIDE * BLOCK_SIDE * BLOCK_SIDE;
/// log2 of [`BLOCK_SIDE`].
pub(crate) const BLOCK_SHIFT: u32 = 3;
/// Block coordinates must lie in `-BLOCK_RANGE..BLOCK_RANGE` (21 bits
/// each in the packed key).
pub(crate) const BLOCK_RANGE: i32 = 1 << 20;

const EMPTY: u64 = u64::MAX;

/// One voxel: the running weighted average of the truncated signed
/// distance (m, positive in front of the surface) and its total weight
/// (0: never observed).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct Voxel {
    pub tsdf: f32,
    pub weight: f32,
}

#[derive(Clone, Copy)]
struct Slot {
    key: u64,
    block: u32,
}

const EMPTY_SLOT: Slot = Slot {
    key: EMPTY,
    block: 0,
};

/// The three bits of a coordinate spread three apart (Morton order).
const SPREAD: [usize; 8] = [0, 1, 8, 9, 64, 65, 72, 73];

/// Index of voxel `v` inside its block (its coordinates modulo 8), in
/// Morton order: each 64-byte cache line holds a 2x2x2 brick, so a ray in
/// any direction meets about half as many lines as with rows along x.
#[inline(always)]
pub(crate) fn local_index(v: [i32; 3]) -> usize {
    let m = BLOCK_SIDE as i32 - 1;
    SPREAD[(v[0] & m) as usize]
        | (SPREAD[(v[1] & m) as usize] << 1)
        | (SPREAD[(v[2] & m) as usize] << 2)
}

/// The block holding voxel `v`.
#[inline(always)]
pub(crate) fn block_of(v: [i32; 3]) -> [i32; 3] {
    [
        v[0] >> BLOCK_SHIFT,
        v[1] >> BLOCK_SHIFT,
        v[2] >> BLOCK_SHIFT,
    ]
}

/// Packs in-range block coordinates into one key (never [`EMPTY`]).
#[inline(always)]
fn pack(b: [i32; 3]) -> u64 {
    let f = |c: i32| (c + BLOCK_RANGE) as u64 & ((1 << 21) - 1);
    (f(b[0]) << 42) | (f(b[1]) << 21) | f(b[2])
}

#[inline(always)]
fn in_range(b: [i32; 3]) -> bool {
    b.iter().all(|&c| (-BLOCK_RANGE..BLOCK_RANGE).contains(&c))
}

/// Entries of the recent-block cache (8 KiB: stays in L1).
const RECENT: usize = 512;

/// A recently used block: key (block coordinates) and pool entry.
#[derive(Clone, Copy)]
struct Recent {
    key: [i32; 3],
    block: u32,
}

/// Never a block in range.
const NO_RECENT: Recent = Recent {
    key: [i32::MIN; 3],
    block: 0,
};

pub(crate) struct BlockStore {
    /// Direct-mapped by the low bits of the block coordinates: rays of
    /// neighbouring firings cross the same few blocks, so most lookups end
    /// here without hashing.
    recent: Vec<Recent>,
    slots: Vec<Slot>,
    mask: usize,
    /// Block coordinates per pool entry, in allocation order.
    coords: Vec<[i32; 3]>,
    voxels: Vec<Voxel>,
    used: usize,
    max_blocks: usize,
}

impl BlockStore {
    pub(crate) fn new(max_blocks: usize) -> BlockStore {
        let n = table_size(max_blocks);
        BlockStore {
            recent: vec![NO_RECENT; RECENT],
            slots: resident_buffer(n, EMPTY_SLOT),
            mask: n - 1,
            coords: resident_buffer(max_blocks, [0; 3]),
            voxels: resident_buffer(max_blocks * BLOCK_VOXELS, Voxel::default()),
            used: 0,
            max_blocks,
        }
    }

    /// Slot of `key`, or the empty slot where it belongs (the table is at
    /// most half full, so the probe ends).
    #[inline(always)]
    fn probe(&self, key: u64) -> usize {
        let mut i = mix64(key) as usize & self.mask;
        loop {
            let k = self.slots[i].key;
            if k == key || k == EMPTY {
                return i;
            }
            i = (i + 1) & self.mask;
        }
    }

    /// Pool entry of block `b`, if allocated.
    #[inline]
    pub(crate) fn get(&self, b: [i32; 3]) -> Option<u32> {
        if !in_range(b) {
            return None;
        }
        let s = self.slots[self.probe(pack(b))];
        (s.key != EMPTY).then_some(s.block)
    }

    /// Pool entry of block `b`, allocated if new; `None` when the pool is
    /// full (or `b` out of range).
    #[inline]
    pub(crate) fn get_or_insert(&mut self, b: [i32; 3]) -> Option<u32> {
        let r = ((b[0] & 7) | ((b[1] & 7) << 3) | ((b[2] & 7) << 6)) as usize;
        let hit = self.recent[r];
        if hit.key == b {
            return Some(hit.block);
        }
        let n = self.get_or_insert_slow(b)?;
        self.recent[r] = Recent { key: b, block: n };
        Some(n)
    }

    #[inline(never)]
    fn get_or_insert_slow(&mut self, b: [i32; 3]) -> Option<u32> {
        if !in_range(b) {
            return None;
        }
        let key = pack(b);
        let i = self.probe(key);
        if self.slots[i].key != EMPTY {
            return Some(self.slots[i].block);
        }
        if self.used >= self.max_blocks {
            return None;
        }
        let n = self.used;
        self.coords[n] = b;
        self.slots[i] = Slot {
            key,
            block: n as u32,
        };
        self.used += 1;
        Some(n as u32)
    }

    #[inline(always)]
    pub(crate) fn block(&self, n: u32) -> &[Voxel] {
        let base = n as usize * BLOCK_VOXELS;
        &self.voxels[base..base + BLOCK_VOXELS]
    }

    #[cfg(test)]
    pub(crate) fn block_mut(&mut self, n: u32) -> &mut [Voxel] {
        let base = n as usize * BLOCK_VOXELS;
        &mut self.voxels[base..base + BLOCK_VOXELS]
    }

    /// Position in the pool of voxel `local` of block `n`.
    #[inline(always)]
    pub(crate) fn voxel_slot(&self, n: u32, local: usize) -> usize {
        n as usize * BLOCK_VOXELS + local
    }

    #[inline(always)]
    pub(crate) fn voxel_mut(&mut self, slot: usize) -> &mut Voxel {
        &mut self.voxels[slot]
    }

    /// Asks for the cache line of the voxel at `slot`: a hint, without
    /// effect on the results.
    #[inline(always)]
    pub(crate) fn prefetch(&self, slot: usize) {
        #[cfg(target_arch = "x86_64")]
        if let Some(v) = self.voxels.get(slot) {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            // SAFETY: SSE is part of every x86-64 target, and a prefetch
            // never faults (the address is even valid).
            unsafe { _mm_prefetch::<_MM_HINT_T0>((v as *const Voxel).cast()) };
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = slot;
    }

    /// Coordinates of the allocated blocks, in pool order.
    pub(crate) fn coords(&self) -> &[[i32; 3]] {
        &self.coords[..self.used]
    }

    pub(crate) fn used(&self) -> usize {
        self.used
    }

    pub(crate) fn max_blocks(&self) -> usize {
        self.max_blocks
    }

    /// Forgets every block, zeroing the voxels that were in use.
    pub(crate) fn clear(&mut self) {
        self.voxels[..self.used * BLOCK_VOXELS].fill(Voxel::default());
        self.slots.fill(EMPTY_SLOT);
        self.recent.fill(NO_RECENT);
        self.used = 0;
    }

    pub(crate) fn memory_bytes(&self) -> usize {
        self.slots.len() * std::mem::size_of::<Slot>()
            + self.recent.len() * std::mem::size_of::<Recent>()
            + self.coords.len() * std::mem::size_of::<[i32; 3]>()
            + self.voxels.len() * std::mem::size_of::<Voxel>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_and_local_indices_cover_negative_coordinates() {
        assert_eq!(block_of([-1, 0, 8]), [-1, 0, 1]);
        assert_eq!(local_index([-1, 0, 8]), 73);
        assert_eq!(local_index([7, 7, 7]), 511);
        assert_eq!(local_index([0, 1, 0]), 2);
        assert_eq!(local_index([1, 1, 1]), 7);
        let mut seen = [false; BLOCK_VOXELS];
        for x in 0..8 {
            for y in 0..8 {
                for z in 0..8 {
                    seen[local_index([x, y, z])] = true;
                }
            }
        }
        assert!(seen.iter().all(|&s| s));
    }

    #[test]
    fn a_full_pool_refuses_new_blocks_and_keeps_old_ones() {
        let mut s = BlockStore::new(2);
        assert_eq!(s.get_or_insert([0, 0, 0]), Some(0));
        assert_eq!(s.get_or_insert([-1, 5, -BLOCK_RANGE]), Some(1));
        assert_eq!(s.get_or_insert([1, 0, 0]), None);
        assert_eq!(s.get_or_insert([0, 0, 0]), Some(0));
        assert_eq!(s.get([-1, 5, -BLOCK_RANGE]), Some(1));
        assert_eq!(s.get([BLOCK_RANGE, 0, 0]), None);
        s.block_mut(1)[3].weight = 1.0;
        s.clear();
        assert_eq!(s.get([0, 0, 0]), None);
        assert_eq!(s.get_or_insert([1, 0, 0]), Some(0));
        assert!(s.block(1).iter().all(|v| v.weight == 0.0));
        let mut none = BlockStore::new(0);
        assert_eq!(none.get_or_insert([0, 0, 0]), None);
    }
}
