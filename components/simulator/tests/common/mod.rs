//! Grounds, plans and the drive loop the simulator's tests share.

#![allow(dead_code)] // each test file uses its own part

use speleo_physics::{Material, Mesh};
use speleo_simulator::{InternalSim, Verdict};
use speleo_twin::world::shapes::add_box;

/// A floor with its top at `top` up to x = `edge`, and `drop` lower from
/// there to x = 12, each a metre thick, 6 m wide.
pub fn step_down(top: f32, edge: f32, drop: f32, surface: Material) -> Mesh {
    let mut m = Mesh::default();
    add_box(&mut m, [-3.0, -3.0, top - 1.0], [edge, 3.0, top], surface);
    let low = top - drop;
    add_box(&mut m, [edge, -3.0, low - 1.0], [12.0, 3.0, low], surface);
    m
}

/// Straight along x from 0 to `to_m`, a pose every 0.1 m, on the ground
/// the plan believes in: 0 up to x = `edge`, `-drop` beyond.
pub fn straight_plan(to_m: f64, edge: f64, drop: f64) -> Vec<[f64; 4]> {
    let n = (to_m / 0.1).round() as usize;
    (0..=n)
        .map(|i| {
            let x = 0.1 * i as f64;
            let z = if x < edge { 0.0 } else { -drop };
            [x, 0.0, z, 0.0]
        })
        .collect()
}

/// Steps `sim` (begun) to its verdict.
pub fn run_to_verdict(sim: &mut InternalSim) -> Verdict {
    for _ in 0..1_000_000 {
        if let Some(v) = sim.step_without_clouds(50) {
            return v;
        }
    }
    panic!("no verdict");
}
