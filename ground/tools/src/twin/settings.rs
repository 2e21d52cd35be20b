//! The twin's configuration file: a speleo configuration (its `[sim]`,
//! `[rover]` and `[lidar]` tables build the same simulated hardware `sim`
//! builds) with a `[twin]` table that says where the wires go.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use speleo_firmware::config::Config;

use super::links::LinkSettings;
use super::serial_end::SerialSetting;

/// The `[twin]` table.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TwinTable {
    /// The HDL-32E's address: its packets leave from here.
    pub lidar_from: String,
    /// The flight binary's `devices.lidar_bind`.
    pub lidar_to: String,
    /// Its `devices.lidar_position_bind` ("": position packets not sent).
    pub lidar_position_to: String,
    /// The MTi's port: a pseudo-terminal linked from this path, unless
    /// `imu_device` names a serial device.
    pub imu_link: String,
    pub imu_device: String,
    pub imu_baud: u32,
    /// The slcan adapter's port, the same way.
    pub can_link: String,
    pub can_device: String,
    pub can_baud: u32,
}

impl Default for TwinTable {
    fn default() -> Self {
        TwinTable {
            lidar_from: "127.0.0.2:2368".into(),
            lidar_to: "127.0.0.1:2368".into(),
            lidar_position_to: "127.0.0.1:8308".into(),
            imu_link: "/tmp/speleo-hil/imu".into(),
            imu_device: String::new(),
            imu_baud: 921_600,
            can_link: "/tmp/speleo-hil/can".into(),
            can_device: String::new(),
            can_baud: 115_200,
        }
    }
}

impl TwinTable {
    pub fn links(&self) -> Result<LinkSettings, String> {
        let addr = |key: &str, v: &str| {
            v.parse()
                .map_err(|e| format!("twin.{key} = \"{v}\": {e} (expected IP:PORT)"))
        };
        let serial = |link: &str, device: &str, baud: u32| {
            if device.is_empty() {
                SerialSetting::Pty {
                    link: (!link.is_empty()).then(|| PathBuf::from(link)),
                }
            } else {
                SerialSetting::Device {
                    path: device.to_string(),
                    baud,
                }
            }
        };
        Ok(LinkSettings {
            lidar_from: addr("lidar_from", &self.lidar_from)?,
            lidar_to: addr("lidar_to", &self.lidar_to)?,
            lidar_position_to: if self.lidar_position_to.is_empty() {
                None
            } else {
                Some(addr("lidar_position_to", &self.lidar_position_to)?)
            },
            imu: serial(&self.imu_link, &self.imu_device, self.imu_baud),
            can: serial(&self.can_link, &self.can_device, self.can_baud),
        })
    }
}

/// A twin configuration: the simulated hardware and the wires.
pub struct TwinSettings {
    pub config: Config,
    pub table: TwinTable,
    /// The file's text, recorded with the twin's run.
    pub text: String,
}

impl TwinSettings {
    /// The defaults of both parts, for a twin started without a file.
    pub fn defaults() -> TwinSettings {
        TwinSettings {
            config: Config::default(),
            table: TwinTable::default(),
            text: String::new(),
        }
    }

    pub fn load(path: &Path) -> Result<TwinSettings, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        Self::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    pub fn parse(text: &str) -> Result<TwinSettings, String> {
        let mut doc: toml::Table = text.parse().map_err(|e| format!("{e}"))?;
        let table = match doc.remove("twin") {
            Some(t) => TwinTable::deserialize(t).map_err(|e| format!("[twin]: {e}"))?,
            None => TwinTable::default(),
        };
        table.links()?;
        let rest = toml::to_string(&doc).map_err(|e| e.to_string())?;
        let config = Config::from_toml(&rest).map_err(|e| e.to_string())?;
        Ok(TwinSettings {
            config,
            table,
            text: text.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_twin_table_is_taken_out_and_the_rest_is_a_speleo_configuration() {
        let s = TwinSettings::parse(
            "[sim]\nworld = \"short-tube\"\n[twin]\nlidar_to = \"127.0.0.1:12368\"\nlidar_position_to = \"\"\nimu_device = \"/dev/ttyS4\"\n",
        )
        .expect("parse");
        assert_eq!(s.config.sim.world, "short-tube");
        let l = s.table.links().expect("links");
        assert_eq!(l.lidar_to.port(), 12368);
        assert_eq!(l.lidar_position_to, None);
        assert_eq!(
            l.imu,
            SerialSetting::Device {
                path: "/dev/ttyS4".into(),
                baud: 921_600
            }
        );
        assert!(matches!(l.can, SerialSetting::Pty { link: Some(_) }));
    }

    #[test]
    fn the_shipped_twin_configuration_loads_and_validates() {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/twin.toml");
        let s = TwinSettings::load(&p).expect("examples/twin.toml");
        s.config.validate().expect("valid");
        assert_eq!(s.config.sim.world, "short-tube");
    }

    #[test]
    fn a_bad_address_or_an_unknown_key_is_named() {
        let e = TwinSettings::parse("[twin]\nlidar_to = \"nowhere\"\n")
            .err()
            .expect("refused");
        assert!(e.contains("twin.lidar_to"), "{e}");
        let e = TwinSettings::parse("[twin]\nlidar_too = \"127.0.0.1:1\"\n")
            .err()
            .expect("refused");
        assert!(e.contains("lidar_too"), "{e}");
    }
}
