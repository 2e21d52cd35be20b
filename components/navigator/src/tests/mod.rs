//! The navigator's tests, on maps and clouds built here: no bus, no
//! schedule, no world.

mod exploration;
mod queries;
mod recovery;
mod rig;
mod validation;

use speleo_exploration::{CandidateParams, ExplorerParams};
use speleo_mapping::mls::MlsParams;
use speleo_messages::{PlanMsg, SlamPose};
use speleo_scheduler::coprocessor::Coprocessor;
use speleo_simulator::InternalSim;

use crate::{Exploration, Navigator, NavigatorParams, Rehearsal};
use rig::{Rig, Scans};

/// The exploration's settings the tests vary, with the rest at the
/// rover's defaults.
#[derive(Default)]
struct Settings {
    weight_target: f64,
    max_goal_rock_m: f64,
}

impl Settings {
    fn explorer_params(&self) -> ExplorerParams {
        ExplorerParams::default()
    }

    fn candidate_params(&self) -> CandidateParams {
        CandidateParams {
            weight_target: self.weight_target,
            max_rock_m: self.max_goal_rock_m,
            ..CandidateParams::default()
        }
    }
}

/// The internal simulator on a thread of its own, a batch of `units` a
/// frame, as the rover's worker core runs it.
struct Worker {
    cp: Coprocessor<InternalSim>,
    units: u32,
}

fn batch(sim: &mut InternalSim, units: u32) {
    let _ = sim.step_without_clouds(units as usize);
}

impl Worker {
    fn spawn(units: u32) -> Self {
        let cp = Coprocessor::spawn("test-sim", 0, batch).unwrap_or_else(|e| panic!("{e}"));
        Worker { cp, units }
    }
}

impl Rehearsal for Worker {
    fn offloads(&self) -> bool {
        true
    }

    fn join(&mut self) -> Option<Box<InternalSim>> {
        self.cp.join().map(|(sim, _)| sim)
    }

    fn lend(&mut self, sim: Box<InternalSim>) -> Result<(), Box<InternalSim>> {
        if sim.needs_clouds() {
            return Err(sim);
        }
        self.cp.lend(sim, self.units)
    }
}

fn rig_on_a_floor() -> Rig {
    let mut pts = Vec::new();
    for i in 0..240 {
        for j in 0..80 {
            let (x, y) = (i as f64 * 0.05 + 0.025, j as f64 * 0.05 + 0.025);
            let rock = (x - 6.0).powi(2) + (y - 2.0).powi(2) < 0.36;
            pts.push([x, y, if rock { 0.5 } else { 0.0 }]);
        }
    }
    rig_with_map(&pts, [1.0, 2.0, 0.17])
}

/// A rig whose serving map holds `pts`, with the rover's SLAM pose at
/// `at`, level and heading along x.
fn rig_with_map(pts: &[[f64; 3]], at: [f64; 3]) -> Rig {
    let mut rig = Rig::with_map(MlsParams::default());
    rig.map.insert_points(pts);
    rig.slam.publish(
        0,
        SlamPose {
            position: at,
            orientation: [1.0, 0.0, 0.0, 0.0],
            keyframes: 1,
        },
    );
    rig
}

fn task(route: &[[f64; 2]]) -> Navigator {
    let cfg = NavigatorParams::default();
    let prims = speleo_planner::primitives::generate(&Default::default());
    Navigator::new(&cfg, &prims, 0.1, route, false, 0.17).unwrap_or_else(|e| panic!("{e}"))
}

/// Steps until the first query ends; the frames it took.
fn run_query(t: &mut Navigator, rig: &mut Rig) -> u64 {
    for f in 0..20_000 {
        let more = rig.step(t, f, 32);
        if !more && f > 0 {
            return f;
        }
    }
    panic!("the query never ended: {:?}", t.counters);
}

fn exploring_task() -> Navigator {
    let e = Settings::default();
    task(&[]).with_exploration(Exploration::new(
        e.explorer_params(),
        e.candidate_params(),
        None,
        0.0,
    ))
}

/// Height of the ledge: over the planner's configured step, but the
/// rover (0.19 m wheels) climbs no more than about 0.2 m.
const LEDGE_M: f64 = 0.3;

/// A 16 x 4 m corridor with a ledge across it at x = 10, seen densely
/// from three keyframes along it; the rover at (`rover_x`, 2). Closed,
/// a wall shuts the corridor's near end.
fn rig_before_a_ledge(rover_x: f64, closed: bool) -> Rig {
    let ground = |x: f64, _| if x < 10.0 { 0.0 } else { LEDGE_M };
    let sensors = [[4.0, 2.0, 0.8], [8.0, 2.0, 0.8], [12.0, 2.0, 1.1]];
    rig_in_a_corridor(ground, closed, [rover_x, 2.0, 0.17], &sensors)
}

/// A 16 x 4 m corridor along x of floor `ground(x, y)`, a face
/// wherever it steps along x, seen densely from `sensors`; the rover at
/// `rover`. Closed, a wall shuts the corridor's near end.
fn rig_in_a_corridor(
    ground: impl Fn(f64, f64) -> f64,
    closed: bool,
    rover: [f64; 3],
    sensors: &[[f64; 3]],
) -> Rig {
    let mut pts = Vec::new();
    for i in 0..320 {
        for j in 0..80 {
            let (x, y) = (i as f64 * 0.05 + 0.025, j as f64 * 0.05 + 0.025);
            let z = ground(x, y);
            pts.push([x, y, z]);
            // Walls along both sides: a corridor open at its ends.
            if j == 0 || j == 79 {
                for k in 1..20 {
                    pts.push([x, y, z + 0.05 * k as f64]);
                }
            }
            if closed && i == 0 {
                for k in 1..20 {
                    pts.push([0.0, y, 0.05 * k as f64]);
                }
            }
            // The face between this column and the next.
            let next = ground(x + 0.05, y);
            let mut h = z.min(next) + 0.05;
            while h < z.max(next) {
                pts.push([x + 0.025, y, h]);
                h += 0.05;
            }
        }
    }
    let mut rig = rig_with_map(&pts, rover);
    rig.scans = Scans::of(&pts, sensors);
    rig
}

/// Exploration before the ledge, plans validated in the simulator (on
/// a worker core when `worker_units` > 0) until one is marked to be
/// driven: the counters, the plan and the frame it came at.
/// The counters, the plan driven, and the frame it came at with the
/// frames spent validating.
/// Exploration with the default settings, every plan validated in
/// a default internal simulator.
fn validating_exploration() -> Exploration {
    let e = Settings::default();
    let sim =
        speleo_simulator::InternalSim::new(Default::default()).unwrap_or_else(|e| panic!("{e}"));
    Exploration::new(e.explorer_params(), e.candidate_params(), None, 0.0).with_simulator(sim)
}

fn nearest_m(plan: &PlanMsg, at: [f64; 2]) -> f64 {
    plan.poses
        .iter()
        .map(|p| (p[0] as f64 - at[0]).hypot(p[1] as f64 - at[1]))
        .fold(f64::INFINITY, f64::min)
}
