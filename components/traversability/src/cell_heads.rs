//! The first node of each cell. Growth looks up the eight neighbours of
//! every node it expands: in a hash map those lookups land anywhere in a
//! megabyte and a half of table, and each missed the caches once the other
//! tasks had run. Over a growth window the heads are a dense grid instead,
//! where a node's neighbours lie in three rows next to each other. Cells
//! outside the window (or every cell, when there is no window or it is
//! larger than the grid reserved) go to the hash map.

use std::collections::HashMap;

use foldhash::fast::FixedState;

use crate::map::{Window, NONE};

pub(crate) struct CellHeads {
    /// Row-major heads over `window`'s cells, when it is in use.
    grid: Vec<u32>,
    window: Option<Window>,
    width: usize,
    /// Hashed with a fixed seed, and fast: the lookups were a tenth of a
    /// growth's time with the standard library's keyed hash.
    hashed: HashMap<(i32, i32), u32, FixedState>,
}

impl CellHeads {
    /// Storage for `max_nodes` hashed heads and a grid of `grid_cells`,
    /// taken now.
    pub(crate) fn new(max_nodes: usize, grid_cells: usize) -> Self {
        CellHeads {
            grid: Vec::with_capacity(grid_cells),
            window: None,
            width: 0,
            hashed: HashMap::with_capacity_and_hasher(max_nodes, FixedState::with_seed(0)),
        }
    }

    /// No heads, the grid over `window` if it fits the storage taken.
    pub(crate) fn reset(&mut self, window: Option<Window>) {
        self.hashed.clear();
        self.grid.clear();
        self.window = window.filter(|w| w.cells() > 0 && w.cells() <= self.grid.capacity());
        if let Some(w) = self.window {
            self.width = (w.max.0 - w.min.0 + 1) as usize;
            self.grid.resize(w.cells(), NONE);
        }
    }

    /// The grid index of `(ix, iy)`, inside the window in use.
    fn at(&self, ix: i32, iy: i32) -> Option<usize> {
        let w = self.window?;
        let inside = ix >= w.min.0 && iy >= w.min.1 && ix <= w.max.0 && iy <= w.max.1;
        inside.then(|| (iy - w.min.1) as usize * self.width + (ix - w.min.0) as usize)
    }

    /// The first node of `(ix, iy)`, [`NONE`] when it has none.
    #[inline]
    pub(crate) fn get(&self, ix: i32, iy: i32) -> u32 {
        match self.at(ix, iy) {
            Some(k) => self.grid[k],
            None => self.hashed.get(&(ix, iy)).copied().unwrap_or(NONE),
        }
    }

    /// Make `i` the first node of `(ix, iy)`; the one before it, or NONE.
    pub(crate) fn push_front(&mut self, ix: i32, iy: i32, i: u32) -> u32 {
        match self.at(ix, iy) {
            Some(k) => std::mem::replace(&mut self.grid[k], i),
            None => self.hashed.insert((ix, iy), i).unwrap_or(NONE),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heads_inside_and_outside_the_window_are_kept_alike() {
        let w = Window {
            min: (-2, 3),
            max: (4, 6),
        };
        let mut h = CellHeads::new(16, w.cells());
        for window in [Some(w), None] {
            h.reset(window);
            assert_eq!(h.get(0, 4), NONE);
            assert_eq!(h.push_front(0, 4, 7), NONE);
            assert_eq!(h.push_front(0, 4, 9), 7);
            assert_eq!(h.push_front(-3, 4, 1), NONE, "left of the window");
            assert_eq!(h.push_front(4, 6, 2), NONE, "the window's corner");
            assert_eq!((h.get(0, 4), h.get(-3, 4), h.get(4, 6)), (9, 1, 2));
            assert_eq!(h.get(1, 4), NONE);
        }
        // A window larger than the grid reserved hashes every cell.
        h.reset(Some(Window {
            min: (0, 0),
            max: (100, 100),
        }));
        assert_eq!(h.push_front(50, 50, 3), NONE);
        assert_eq!(h.get(50, 50), 3);
    }
}
