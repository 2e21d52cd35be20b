//! `[planner]`: the traversability graph and the anytime multi-level ARA*
//! planner run by the `planner` task over the serving MLS map. The table
//! holds the navigator's settings (`speleo_navigator::NavigatorParams`),
//! the graph's (`speleo_traversability::TravParams`) and the lattice's
//! (`speleo_planner::surface::SurfaceParams`) side by side, with the
//! task's own keys; the components' docs describe each.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use speleo_navigator::NavigatorParams;
use speleo_planner::surface::SurfaceParams;
use speleo_traversability::TravParams;

use super::compose::Section;
use super::{ConfigError, PlannerStepUnits};

#[derive(Clone, Debug, PartialEq)]
pub struct PlannerConfig {
    /// Plan (needs the maps).
    pub enabled: bool,
    /// The navigator's settings with the graph's (`nav.trav`) and the
    /// lattice's (`nav.surface`). The defaults are the navigator's: the
    /// graph held to 2^16 nodes (the garage's levels fill 2^16 in most
    /// queries; at 2^18, 251 MB, garage seed 1 took another course and
    /// was stranded on ramp 1→2's side, where at 2^16 it comes home).
    pub nav: NavigatorParams,
    /// An SBPL `.mprim` file at the map's resolution; empty: the
    /// generated set for the rover (`speleo primitives`).
    pub mprim: String,
    /// Work units of one step in each phase (`[planner.step_units]`).
    pub step_units: PlannerStepUnits,
}

impl Default for PlannerConfig {
    /// The navigator's defaults (`NavigatorParams::default`).
    fn default() -> Self {
        PlannerConfig {
            enabled: true,
            nav: NavigatorParams::default(),
            mprim: String::new(),
            step_units: PlannerStepUnits::default(),
        }
    }
}

impl PlannerConfig {
    pub(super) fn validate(&self, mls_resolution_m: f64) -> Result<(), ConfigError> {
        self.nav
            .validate()
            .map_err(|e| ConfigError::of_param("planner", e))?;
        let cells = (self.nav.window_max_m / mls_resolution_m + 2.0).powi(2);
        if cells > 64e6 {
            return Err(ConfigError::Invalid {
                key: "planner.window_max_m".into(),
                why: format!("{cells:.0} cells of maps.mls_resolution_m: at most 64 M"),
            });
        }
        self.step_units.validate()
    }

    pub fn trav_params(&self) -> TravParams {
        self.nav.trav.clone()
    }

    pub fn surface_params(&self) -> SurfaceParams {
        self.nav.surface.clone()
    }

    /// The navigator's settings.
    pub fn navigator_params(&self) -> NavigatorParams {
        self.nav.clone()
    }

    /// Cells of the lattice's map table for the largest growth window at
    /// `resolution_m`.
    pub fn window_cells(&self, resolution_m: f64) -> usize {
        speleo_planner::surface::grid_cells_for_window(
            self.nav.window_max_m,
            resolution_m,
            &self.nav.surface,
        )
    }
}

impl<'de> Deserialize<'de> for PlannerConfig {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let read = |table| -> Result<Self, String> {
            let base = PlannerConfig::default();
            let mut s = Section::new("planner", table);
            let enabled = s.own("enabled")?.unwrap_or(base.enabled);
            let mut nav = s.part(&base.nav)?;
            nav.trav = s.part(&base.nav.trav)?;
            nav.surface = s.part(&base.nav.surface)?;
            let mprim = s.own("mprim")?.unwrap_or(base.mprim);
            let step_units = s.own("step_units")?.unwrap_or(base.step_units);
            s.finish()?;
            Ok(PlannerConfig {
                enabled,
                nav,
                mprim,
                step_units,
            })
        };
        read(toml::Table::deserialize(d)?).map_err(serde::de::Error::custom)
    }
}

impl Serialize for PlannerConfig {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Table<'a> {
            enabled: bool,
            #[serde(flatten)]
            nav: &'a NavigatorParams,
            #[serde(flatten)]
            trav: &'a TravParams,
            #[serde(flatten)]
            surface: &'a SurfaceParams,
            mprim: &'a str,
            step_units: &'a PlannerStepUnits,
        }
        Table {
            enabled: self.enabled,
            nav: &self.nav,
            trav: &self.nav.trav,
            surface: &self.nav.surface,
            mprim: &self.mprim,
            step_units: &self.step_units,
        }
        .serialize(s)
    }
}
