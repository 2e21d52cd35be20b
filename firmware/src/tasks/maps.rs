//! The maps task: the map builder (`speleo_mapping::MapBuilder`) as an
//! anytime task. Each step does up to its quantum of the builder's units,
//! from the keyframe clouds into the surface maps.

use speleo_mapping::{BuilderParams, MapBuilder};
use speleo_scheduler::{Context, StepResult, Task};

use crate::bus::Bus;
use crate::config::MapsConfig;

pub struct MapsTask {
    pub builder: MapBuilder,
}

impl MapsTask {
    /// The task for `keyframes` keyframes, as `[maps]` configures it; the
    /// maps themselves are the bus's (`SurfaceMaps::new(cfg.mls_params())`).
    pub fn new(cfg: &MapsConfig, keyframes: usize) -> Self {
        let p = BuilderParams {
            points_per_step: cfg.points_per_step,
            reproject_m: cfg.reproject_m,
            reproject_deg: cfg.reproject_deg,
            keep_radius_m: cfg.mls_keep_radius_m,
            range_m: cfg.range_m,
        };
        MapsTask {
            builder: MapBuilder::new(&p, cfg.mls_params().max_cells, keyframes),
        }
    }
}

impl Task<Bus> for MapsTask {
    fn run(&mut self, _bus: &mut Bus, _cx: &Context) {}

    fn step(&mut self, bus: &mut Bus, _cx: &Context, quantum: u32) -> StepResult {
        for _ in 0..quantum.max(1) {
            if !self.builder.work(&bus.keyframe_clouds, &mut bus.surface) {
                return StepResult::Idle;
            }
        }
        StepResult::Continue
    }
}
