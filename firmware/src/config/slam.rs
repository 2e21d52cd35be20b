//! `[slam]`: whether SLAM runs, and its settings
//! (`speleo_slam::graph_slam::SlamParams`, see components/slam/README.md),
//! written in the same table.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use speleo_slam::graph_slam::SlamParams;

use super::compose::Section;

#[derive(Clone, Debug, PartialEq)]
pub struct SlamConfig {
    /// Run SLAM when a LiDAR is present.
    pub enabled: bool,
    pub params: SlamParams,
}

impl Default for SlamConfig {
    fn default() -> Self {
        SlamConfig {
            enabled: true,
            params: SlamParams::default(),
        }
    }
}

impl SlamConfig {
    pub fn params(&self) -> SlamParams {
        self.params.clone()
    }
}

impl<'de> Deserialize<'de> for SlamConfig {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let read = |table| -> Result<Self, String> {
            let base = SlamConfig::default();
            let mut s = Section::new("slam", table);
            let enabled = s.own("enabled")?.unwrap_or(base.enabled);
            let params = s.part(&base.params)?;
            s.finish()?;
            Ok(SlamConfig { enabled, params })
        };
        read(toml::Table::deserialize(d)?).map_err(serde::de::Error::custom)
    }
}

impl Serialize for SlamConfig {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Table<'a> {
            enabled: bool,
            #[serde(flatten)]
            params: &'a SlamParams,
        }
        Table {
            enabled: self.enabled,
            params: &self.params,
        }
        .serialize(s)
    }
}
