//! The two multi-level surface maps on the bus: the one that serves (the
//! planner reads it) and the spare the `maps` task rebuilds into after a
//! loop closure or when the serving one is full. Written by `maps` only.

use crate::mls::{MlsMap, MlsParams, MlsStats};
use crate::ParamsError;

pub struct SurfaceMaps {
    maps: [MlsMap; 2],
    active: usize,
    /// Changes whenever the serving map changes (an insertion or a swap).
    generation: u64,
}

impl SurfaceMaps {
    /// Two maps of `params`, taken now.
    pub fn new(params: MlsParams) -> Result<Self, ParamsError> {
        Ok(SurfaceMaps {
            maps: [MlsMap::new(params.clone())?, MlsMap::new(params)?],
            active: 0,
            generation: 0,
        })
    }

    /// Two one-cell maps, for a run without maps.
    pub fn empty() -> Self {
        let params = MlsParams {
            max_cells: 1,
            ..MlsParams::default()
        };
        match SurfaceMaps::new(params) {
            Ok(m) => m,
            // The default parameters with one cell are valid.
            Err(e) => unreachable!("one-cell maps: {e}"),
        }
    }

    /// The map that serves queries.
    pub fn serving(&self) -> &MlsMap {
        &self.maps[self.active]
    }

    pub fn stats(&self) -> MlsStats {
        self.serving().stats()
    }

    /// Which map serves (0 or 1).
    pub fn active(&self) -> usize {
        self.active
    }

    /// Map `m` to write into; the serving map's generation moves on.
    pub fn map_mut(&mut self, m: usize) -> &mut MlsMap {
        if m == self.active {
            self.generation += 1;
        }
        &mut self.maps[m]
    }

    /// The spare map becomes the serving one.
    pub fn swap(&mut self) {
        self.active = 1 - self.active;
        self.generation += 1;
    }

    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Both maps' fixed memory.
    pub fn memory_bytes(&self) -> usize {
        self.maps.iter().map(|m| m.stats().memory_bytes).sum()
    }
}
