//! Open-addressing hash index from a cell's integer coordinates to its slot
//! in the cell arrays. Fixed size, linear probing, no deletion: eviction
//! rebuilds it in place.

use crate::hash::{mix64, table_size};

/// Marks an empty slot.
const EMPTY: u32 = u32::MAX;

#[derive(Clone, Copy)]
struct Slot {
    ix: i32,
    iy: i32,
    cell: u32,
}

const EMPTY_SLOT: Slot = Slot {
    ix: 0,
    iy: 0,
    cell: EMPTY,
};

/// Where a key is, or where it would go.
pub(crate) enum Probe {
    Found(u32),
    Vacant(usize),
}

pub(crate) struct CellIndex {
    slots: Vec<Slot>,
    mask: usize,
}

impl CellIndex {
    /// An index for up to `capacity` cells (at most half full).
    pub(crate) fn new(capacity: usize) -> CellIndex {
        let n = table_size(capacity);
        CellIndex {
            slots: crate::resident_buffer(n, EMPTY_SLOT),
            mask: n - 1,
        }
    }

    /// The slot where the search for `(ix, iy)` starts.
    #[inline(always)]
    pub(crate) fn home(&self, ix: i32, iy: i32) -> usize {
        let key = ((ix as u32 as u64) << 32) | iy as u32 as u64;
        mix64(key) as usize & self.mask
    }

    /// Finds the cell of `(ix, iy)` or the empty slot where it belongs.
    /// Terminates: the table is never more than half full.
    #[inline(always)]
    pub(crate) fn probe(&self, ix: i32, iy: i32) -> Probe {
        self.probe_from(self.home(ix, iy), ix, iy)
    }

    /// [`CellIndex::probe`] from `home`, the key's [`CellIndex::home`].
    #[inline(always)]
    pub(crate) fn probe_from(&self, home: usize, ix: i32, iy: i32) -> Probe {
        let mut i = home & self.mask;
        loop {
            let s = self.slots[i];
            if s.cell == EMPTY {
                return Probe::Vacant(i);
            }
            if s.ix == ix && s.iy == iy {
                return Probe::Found(s.cell);
            }
            i = (i + 1) & self.mask;
        }
    }

    /// Asks for the cache line of slot `i`: a hint, without effect.
    #[inline(always)]
    pub(crate) fn prefetch(&self, i: usize) {
        if let Some(s) = self.slots.get(i) {
            crate::prefetch(s);
        }
    }

    pub(crate) fn get(&self, ix: i32, iy: i32) -> Option<u32> {
        match self.probe(ix, iy) {
            Probe::Found(c) => Some(c),
            Probe::Vacant(_) => None,
        }
    }

    /// Fills the vacant slot `at` (from [`CellIndex::probe`] with the same
    /// key and no insertion since).
    #[inline(always)]
    pub(crate) fn fill(&mut self, at: usize, ix: i32, iy: i32, cell: u32) {
        self.slots[at] = Slot { ix, iy, cell };
    }

    /// Inserts a key known to be absent.
    pub(crate) fn insert_new(&mut self, ix: i32, iy: i32, cell: u32) {
        if let Probe::Vacant(at) = self.probe(ix, iy) {
            self.fill(at, ix, iy, cell);
        }
    }

    pub(crate) fn clear(&mut self) {
        self.slots.fill(EMPTY_SLOT);
    }

    pub(crate) fn memory_bytes(&self) -> usize {
        self.slots.len() * std::mem::size_of::<Slot>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_what_was_filled_and_nothing_else() {
        let mut idx = CellIndex::new(100);
        for k in 0..100 {
            let (ix, iy) = (k % 10 - 5, k / 10 - 5);
            match idx.probe(ix, iy) {
                Probe::Vacant(at) => idx.fill(at, ix, iy, k as u32),
                Probe::Found(_) => panic!("duplicate"),
            }
        }
        for k in 0..100 {
            assert_eq!(idx.get(k % 10 - 5, k / 10 - 5), Some(k as u32));
        }
        assert_eq!(idx.get(5, 5), None);
        idx.clear();
        assert_eq!(idx.get(0, 0), None);
    }
}
