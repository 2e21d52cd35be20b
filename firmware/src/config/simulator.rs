//! `[simulator]`: the internal simulator that drives every exploration
//! plan on the rover's own map before the rover drives it. The table holds
//! the simulator's settings (`speleo_simulator::SimulatorParams`, whose
//! docs describe each) with the task's own keys.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use speleo_simulator::SimulatorParams;

use super::compose::Section;
use super::{range, ConfigError};

#[derive(Clone, Debug, PartialEq)]
pub struct SimulatorConfig {
    /// Validate each exploration plan in simulation first (the default):
    /// a plan the simulated rover does not drive to its goal is refused
    /// and the next goal tried. Off: plans are driven as planned.
    pub enabled: bool,
    /// The simulator's settings; the rover's build, the follower and the
    /// base's height come from `[sim]`, `[control]` and `[rover]`, and
    /// `tip_over_deg` is capped by `control.max_tilt_deg`, where the
    /// safety monitor would stop the rover (`mission::simulator_params`).
    pub params: SimulatorParams,
    /// Work units a frame done on a core of its own (a worker thread the
    /// planner task lends the validation to and takes it back from the
    /// next frame): everything but the clouds' integration. A physics
    /// step is 6 units, so 120 drives the simulated rover 20 times faster
    /// than real time at 10 ms steps (the default). 0: all the work in
    /// the planner's own window (`planner.step_units.validate` a frame),
    /// 2x real time, for a computer with one core.
    pub worker_units: u32,
    /// Write every validation's inputs and verdict to this folder as
    /// validation-NNNN.case, for `speleo validate` (`speleo sim
    /// --dump-validations`). A debugging aid: files written from the
    /// planner task. Off by default.
    pub dump_dir: Option<std::path::PathBuf>,
}

impl Default for SimulatorConfig {
    fn default() -> Self {
        SimulatorConfig {
            enabled: true,
            params: SimulatorParams::default(),
            worker_units: 120,
            dump_dir: None,
        }
    }
}

impl SimulatorConfig {
    pub(super) fn validate(&self) -> Result<(), ConfigError> {
        self.params
            .validate()
            .map_err(|e| ConfigError::of_param("simulator", e))?;
        range(
            "simulator.worker_units",
            self.worker_units,
            0,
            4096,
            "0..=4096",
        )
    }
}

impl<'de> Deserialize<'de> for SimulatorConfig {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let read = |table| -> Result<Self, String> {
            let base = SimulatorConfig::default();
            let mut s = Section::new("simulator", table);
            let enabled = s.own("enabled")?.unwrap_or(base.enabled);
            let params = s.part(&base.params)?;
            let worker_units = s.own("worker_units")?.unwrap_or(base.worker_units);
            let dump_dir = s.own("dump_dir")?;
            s.finish()?;
            Ok(SimulatorConfig {
                enabled,
                params,
                worker_units,
                dump_dir,
            })
        };
        read(toml::Table::deserialize(d)?).map_err(serde::de::Error::custom)
    }
}

impl Serialize for SimulatorConfig {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Table<'a> {
            enabled: bool,
            #[serde(flatten)]
            params: &'a SimulatorParams,
            worker_units: u32,
            #[serde(skip_serializing_if = "Option::is_none")]
            dump_dir: &'a Option<std::path::PathBuf>,
        }
        Table {
            enabled: self.enabled,
            params: &self.params,
            worker_units: self.worker_units,
            dump_dir: &self.dump_dir,
        }
        .serialize(s)
    }
}
