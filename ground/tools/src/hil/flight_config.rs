//! The flight binary's configuration on the bench: its devices pointed at
//! the twin's wires, so the two cannot disagree.

use std::path::Path;

use crate::twin::serial_end::SerialSetting;
use crate::twin::settings::TwinSettings;
use crate::Error;

/// The flight binary's configuration: `base` (or the defaults) with its
/// devices at the twin's wires, as `twin` (or its defaults) places them.
pub(super) fn write_flight_config(
    twin: Option<&Path>,
    base: Option<&Path>,
    out: &Path,
) -> Result<(), Error> {
    let t = match twin {
        Some(p) => TwinSettings::load(p)?,
        None => TwinSettings::defaults(),
    };
    let mut doc: toml::Table = match base {
        Some(p) => std::fs::read_to_string(p)
            .map_err(|e| format!("cannot read {}: {e}", p.display()))?
            .parse()
            .map_err(|e| format!("{}: {e}", p.display()))?,
        None => toml::Table::new(),
    };
    let links = t.table.links()?;
    let port = |s: &SerialSetting, link: &str| match s {
        SerialSetting::Device { path, .. } => path.clone(),
        SerialSetting::Pty { .. } => link.to_string(),
    };
    let devices = doc
        .entry("devices")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    let toml::Value::Table(d) = devices else {
        return Err("[devices] is not a table".into());
    };
    let s = |v: &str| toml::Value::String(v.to_string());
    d.insert("lidar_bind".into(), s(&links.lidar_to.to_string()));
    d.insert(
        "lidar_position_bind".into(),
        s(&links
            .lidar_position_to
            .map_or(String::new(), |a| a.to_string())),
    );
    d.insert("lidar_sensor".into(), s(&links.lidar_from.to_string()));
    d.insert("imu_port".into(), s(&port(&links.imu, &t.table.imu_link)));
    d.insert(
        "imu_baud".into(),
        toml::Value::Integer(t.table.imu_baud.into()),
    );
    d.insert("can_transport".into(), s("slcan"));
    d.insert(
        "can_serial_port".into(),
        s(&port(&links.can, &t.table.can_link)),
    );
    d.insert(
        "can_serial_baud".into(),
        toml::Value::Integer(t.table.can_baud.into()),
    );
    let text = toml::to_string(&doc).map_err(|e| e.to_string())?;
    speleo_firmware::config::Config::from_toml(&text)
        .map_err(|e| format!("the flight configuration for the bench: {e}"))?;
    std::fs::write(out, text).map_err(|e| format!("writing {}: {e}", out.display()))?;
    Ok(())
}
