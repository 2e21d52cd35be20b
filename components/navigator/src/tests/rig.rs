//! The mailboxes a navigator reads and writes, without a bus: what the
//! planner task does for it on the rover, done here for the tests.

use speleo_mapping::mls::{MlsMap, MlsParams};
use speleo_messages::{DriveFeedback, ExplorationStatus, PlanMsg, SlamPose, WheelCommand};
use speleo_scheduler::mailbox::Latest;
use speleo_simulator::CloudSource;

use crate::{Exploration, InStep, NavInput, Navigator, Outbox, Rehearsal};

/// The planner's default units a phase (`[planner.step_units]`), each
/// capped by the quantum the test steps with.
const STEP_UNITS: [u32; 6] = [54, 128, 35, 19, 18, 14];
/// The rover keeps keyframe points in steps of this, m.
const LSB_M: f64 = 0.002;

/// Keyframe clouds: each keyframe's points relative to its sensor, and the
/// sensor's position (level, no rotation). Points are kept in 2 mm steps,
/// as the rover keeps them.
#[derive(Default)]
pub(crate) struct Scans {
    pub origins: Vec<[f64; 3]>,
    pub points: Vec<Vec<[f64; 3]>>,
}

impl Scans {
    /// `world` seen from each of `sensors`.
    pub fn of(world: &[[f64; 3]], sensors: &[[f64; 3]]) -> Self {
        Scans {
            origins: sensors.to_vec(),
            points: sensors
                .iter()
                .map(|o| {
                    world
                        .iter()
                        .map(|p| {
                            let q = |c: f64| (c / LSB_M).round() as i16 as f64 * LSB_M;
                            [q(p[0] - o[0]), q(p[1] - o[1]), q(p[2] - o[2])]
                        })
                        .collect()
                })
                .collect(),
        }
    }
}

impl CloudSource for Scans {
    fn keyframes(&self) -> usize {
        self.origins.len()
    }

    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        self.origins.get(k).copied()
    }

    fn points(&self, k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        out.clear();
        let (Some(o), Some(cloud)) = (self.origins.get(k), self.points.get(k)) else {
            return false;
        };
        let part = &cloud[from.min(cloud.len())..(from + n).min(cloud.len())];
        out.extend(part.iter().map(|q| [q[0] + o[0], q[1] + o[1], q[2] + o[2]]));
        from + n < cloud.len()
    }
}

pub(crate) struct Rig {
    pub slam: Latest<SlamPose>,
    pub command: Latest<WheelCommand>,
    pub drives: Latest<DriveFeedback>,
    pub plan: Latest<PlanMsg>,
    pub exploration: ExplorationStatus,
    pub map: MlsMap,
    pub scans: Scans,
    /// Where direct calls to an exploration publish.
    out: Outbox,
}

impl Rig {
    /// Nothing published, a one-cell map, no clouds.
    pub fn new() -> Self {
        Self::with_map(MlsParams {
            max_cells: 1,
            ..MlsParams::default()
        })
    }

    pub fn with_map(params: MlsParams) -> Self {
        Rig {
            slam: Latest::new(),
            command: Latest::new(),
            drives: Latest::new(),
            plan: Latest::new(),
            exploration: ExplorationStatus::default(),
            map: MlsMap::new(params).unwrap_or_else(|e| panic!("{e}")),
            scans: Scans::default(),
            out: Outbox::new(),
        }
    }

    /// What the mailboxes hold at `now_ns`, as the navigator reads it.
    pub fn input(&self, now_ns: u64) -> NavInput<'_> {
        NavInput {
            now_ns,
            slam: self.slam.get(),
            command: self.command.get(),
            drives: self.drives.get().copied(),
            map: &self.map,
            clouds: &self.scans,
        }
    }

    /// One planner step of frame `frame` (10 ms frames) with `quantum`
    /// units at most, its simulation in the step; whether it goes on.
    pub fn step(&mut self, nav: &mut Navigator, frame: u64, quantum: u32) -> bool {
        self.step_hosted(nav, frame, quantum, &mut InStep)
    }

    /// [`Rig::step`] with the simulation hosted by `host`.
    pub fn step_hosted(
        &mut self,
        nav: &mut Navigator,
        frame: u64,
        quantum: u32,
        host: &mut dyn Rehearsal,
    ) -> bool {
        let units = nav
            .timed_phase()
            .map_or(quantum, |i| STEP_UNITS[i].min(quantum))
            .max(1);
        let now = frame * 10_000_000;
        let more = nav.step(&self.input(now), units, host);
        let plan = &mut self.plan;
        nav.take_plans(|p| plan.publish(now, p.clone()));
        self.exploration = nav.status();
        more
    }

    /// Run `f` on `ex` as the planner task would at `now`, publishing what
    /// it publishes.
    fn with<R>(&mut self, now: u64, f: impl FnOnce(&NavInput, &mut Outbox) -> R) -> R {
        self.out.status = self.exploration;
        let input = NavInput {
            now_ns: now,
            slam: self.slam.get(),
            command: self.command.get(),
            drives: self.drives.get().copied(),
            map: &self.map,
            clouds: &self.scans,
        };
        let r = f(&input, &mut self.out);
        let plan = &mut self.plan;
        self.out.drain(|p| plan.publish(now, p.clone()));
        self.exploration = self.out.status;
        r
    }

    pub fn observe(&mut self, ex: &mut Exploration, now: u64) {
        self.with(now, |i, o| ex.observe(i, o));
    }

    pub fn ready(&mut self, ex: &mut Exploration, now: u64) -> bool {
        self.with(now, |i, o| ex.ready(i, o))
    }

    pub fn retrace(&mut self, ex: &mut Exploration, now: u64, query: u64, ahead_m: f64) -> bool {
        self.with(now, |i, o| ex.retrace(i, o, query, ahead_m))
    }

    /// The plan shown last.
    pub fn published(&self) -> PlanMsg {
        self.plan
            .get()
            .unwrap_or_else(|| panic!("no plan published"))
            .value
            .clone()
    }
}
