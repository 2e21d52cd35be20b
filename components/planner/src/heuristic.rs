//! The cost-to-go of every cell on a lattice that forgets the heading: a
//! cell's successors are the ends of every action of every heading, at the
//! actions' own costs. Every path of the real lattice is a path of this
//! one at the same cost, so its exact costs (Dijkstra backwards from the
//! goal cell) are an admissible and consistent heuristic, and obstacles,
//! cell costs and the primitives' reach all shape it.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::sbpl::SbplLattice;
use crate::INFINITE_COST;

/// Cost-to-go of each cell (`x + y * width`) to the goal cell;
/// [`INFINITE_COST`] where the goal cannot be reached.
pub fn cost_to_go(l: &SbplLattice) -> Vec<u32> {
    let n = l.cell_count();
    let mut h = vec![INFINITE_COST; n];
    let Some(goal) = l.cell_index(l.goal.0, l.goal.1) else {
        return h;
    };
    h[goal] = 0;
    let mut open = BinaryHeap::new();
    open.push(Reverse((0u32, goal as u32)));
    while let Some(Reverse((d, c))) = open.pop() {
        if d > h[c as usize] {
            continue;
        }
        let (x, y) = l.cell_xy(c as usize);
        for a in l.all_actions() {
            let (sx, sy) = (x - a.dx, y - a.dy);
            let Some(s) = l.cell_index(sx, sy) else {
                continue;
            };
            // Every cost is at least the base cost: most actions are
            // passed without looking at their cells.
            if d.saturating_add(a.base_cost) >= h[s] {
                continue;
            }
            let cost = l.action_cost(sx, sy, a);
            if cost == INFINITE_COST {
                continue;
            }
            let nd = d.saturating_add(cost);
            if nd < h[s] {
                h[s] = nd;
                open.push(Reverse((nd, s as u32)));
            }
        }
    }
    h
}
