//! The worker's batch holds its budget on any ground: a physics step with
//! a heavy contact load is charged more than the flat six units. On ground
//! of 5 cm triangles (a TSDF mesh's) a 120-unit batch drives 20 steps, 20x
//! real time (a load of ~230); on ground five times finer each leg meets
//! 25 times the triangles (a load of ~2,700), a step costs several times
//! as much, and a batch drives fewer.

use speleo_physics::{Material, Mesh};
use speleo_simulator::{InternalSim, Outcome, SimulatorParams, Stance};

/// Flat ground at z = 0 from x = -1 to 2.5 m and y = -0.8 to 0.8 m, of
/// right triangles with legs of `cell` m.
fn plane(cell: f64) -> Mesh {
    let (nx, ny) = ((3.5 / cell).round() as u32, (1.6 / cell).round() as u32);
    let mut m = Mesh::default();
    for i in 0..=nx {
        for j in 0..=ny {
            m.vertices.push([
                (-1.0 + i as f64 * cell) as f32,
                (-0.8 + j as f64 * cell) as f32,
                0.0,
            ]);
        }
    }
    for i in 0..nx {
        for j in 0..ny {
            let v = i * (ny + 1) + j;
            let (a, b, c, d) = (v, v + 1, v + ny + 1, v + ny + 2);
            m.triangles.extend([[a, c, d], [a, d, b]]);
            m.materials.extend([Material::Rock; 2]);
        }
    }
    m
}

/// Physics steps of each 120-unit batch wholly spent driving, the largest
/// contact load seen, and the verdict.
fn batches_on(ground: Mesh) -> (Vec<u64>, usize, Outcome) {
    // One rollout: no batch holds the change to the pessimistic one.
    let p = SimulatorParams {
        pessimistic_friction: 0.0,
        ..SimulatorParams::default()
    };
    let start = Stance::level(0.0, 0.0, p.base_height_m, 0.0);
    let plan: Vec<_> = (0..=10).map(|i| [0.1 * i as f64, 0.0, 0.0, 0.0]).collect();
    let mut sim = InternalSim::new(p).expect("sim");
    sim.begin_on(start, plan, ground);
    let (mut steps, mut load) = (Vec::new(), 0);
    for _ in 0..10_000 {
        let driving = sim.work() == "drive";
        let before = sim.counters.physics_steps;
        let verdict = sim.step_without_clouds(120);
        let [_, tests, points] = sim.contact_load();
        load = load.max(tests + points);
        if let Some(v) = verdict {
            return (steps, load, v.outcome);
        }
        if driving {
            steps.push(sim.counters.physics_steps - before);
        }
    }
    panic!("no verdict");
}

#[test]
fn a_physics_step_is_charged_by_its_contact_load() {
    let (coarse, coarse_load, outcome) = batches_on(plane(0.05));
    assert_eq!(outcome, Outcome::Reached);
    assert!(coarse_load < 1200, "{coarse_load}");
    assert!(coarse.iter().all(|&n| n == 20), "{coarse:?}");
    let (fine, fine_load, outcome) = batches_on(plane(0.01));
    assert_eq!(outcome, Outcome::Reached);
    assert!(fine_load > 1600, "{fine_load}");
    assert!(!fine.is_empty() && fine.iter().all(|&n| n < 20), "{fine:?}");
}
