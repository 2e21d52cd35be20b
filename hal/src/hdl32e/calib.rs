//! Laser calibration: the nominal HDL-32E table, VeloView XML and ROS YAML.

use std::path::Path;

use super::LASERS;

/// Nominal elevation of each laser in firing order, degrees.
pub const NOMINAL_ELEVATION_DEG: [f64; LASERS] = [
    -30.67, -9.33, -29.33, -8.00, -28.00, -6.67, -26.67, -5.33, -25.33, -4.00, -24.00, -2.67,
    -22.67, -1.33, -21.33, 0.00, -20.00, 1.33, -18.67, 2.67, -17.33, 4.00, -16.00, 5.33, -14.67,
    6.67, -13.33, 8.00, -12.00, 9.33, -10.67, 10.67,
];

/// Corrections of one laser.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaserCal {
    pub vert_deg: f64,
    pub rot_deg: f64,
    pub dist_correction_m: f64,
    pub vert_offset_m: f64,
    pub horiz_offset_m: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    pub lasers: [LaserCal; LASERS],
    /// Metres per distance unit (0.002 for the HDL-32E).
    pub distance_lsb_m: f64,
    /// Ring of each laser: its rank by elevation, 0 = lowest beam.
    pub ring: [u8; LASERS],
}

#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Format(String),
}

fn rings(lasers: &[LaserCal; LASERS]) -> [u8; LASERS] {
    let mut order: [usize; LASERS] = core::array::from_fn(|i| i);
    order.sort_by(|&a, &b| {
        lasers[a]
            .vert_deg
            .total_cmp(&lasers[b].vert_deg)
            .then(a.cmp(&b))
    });
    let mut ring = [0u8; LASERS];
    for (rank, &laser) in order.iter().enumerate() {
        ring[laser] = rank as u8;
    }
    ring
}

impl Calibration {
    fn checked(lasers: [LaserCal; LASERS], distance_lsb_m: f64) -> Result<Self, CalibError> {
        if !(distance_lsb_m.is_finite() && distance_lsb_m > 0.0 && distance_lsb_m < 1.0) {
            return Err(CalibError::Format(format!(
                "distance unit {distance_lsb_m} m is not a positive length under 1 m"
            )));
        }
        for (i, l) in lasers.iter().enumerate() {
            let v = [
                l.vert_deg,
                l.rot_deg,
                l.dist_correction_m,
                l.vert_offset_m,
                l.horiz_offset_m,
            ];
            if v.iter().any(|x| !x.is_finite()) || l.vert_deg.abs() > 90.0 {
                return Err(CalibError::Format(format!(
                    "laser {i}: corrections out of range"
                )));
            }
        }
        Ok(Self::new(lasers, distance_lsb_m))
    }

    pub fn new(lasers: [LaserCal; LASERS], distance_lsb_m: f64) -> Self {
        Calibration {
            ring: rings(&lasers),
            lasers,
            distance_lsb_m,
        }
    }

    /// The factory elevation angles with no other corrections.
    pub fn nominal() -> Self {
        Self::new(
            NOMINAL_ELEVATION_DEG.map(|v| LaserCal {
                vert_deg: v,
                rot_deg: 0.0,
                dist_correction_m: 0.0,
                vert_offset_m: 0.0,
                horiz_offset_m: 0.0,
            }),
            0.002,
        )
    }

    /// Load a VeloView `.xml` or ROS `.yaml`/`.yml` calibration by extension.
    pub fn load(path: &Path) -> Result<Self, CalibError> {
        let text = std::fs::read_to_string(path).map_err(|source| CalibError::Read {
            path: path.display().to_string(),
            source,
        })?;
        if text.trim().is_empty() {
            return Err(CalibError::Format(format!(
                "{}: the calibration file is empty",
                path.display()
            )));
        }
        let ext = crate::extension_of(path);
        let r = match ext.as_str() {
            "xml" => Self::from_veloview_xml(&text),
            "yaml" | "yml" => Self::from_ros_yaml(&text),
            _ => Err(CalibError::Format(
                "calibration files end in .xml (VeloView) or .yaml/.yml (ROS)".into(),
            )),
        };
        r.map_err(|e| match e {
            CalibError::Format(m) => CalibError::Format(format!("{}: {m}", path.display())),
            other => other,
        })
    }

    /// VeloView's boost-serialised XML (`DB/points_/item/px`). Only the first
    /// 32 entries are used; distances are in centimetres there.
    pub fn from_veloview_xml(text: &str) -> Result<Self, CalibError> {
        // VeloView's files carry a DOCTYPE; nothing in it is used.
        let options = roxmltree::ParsingOptions {
            allow_dtd: true,
            ..roxmltree::ParsingOptions::default()
        };
        let doc = roxmltree::Document::parse_with_options(text, options)
            .map_err(|e| CalibError::Format(format!("not XML: {e}")))?;
        let num = |node: roxmltree::Node<'_, '_>, tag: &str| -> Result<f64, CalibError> {
            let t = node
                .children()
                .find(|c| c.has_tag_name(tag))
                .and_then(|c| c.text())
                .ok_or_else(|| CalibError::Format(format!("a laser has no <{tag}>")))?;
            t.trim()
                .parse::<f64>()
                .map_err(|e| CalibError::Format(format!("<{tag}>{t}</{tag}>: {e}")))
        };
        let lsb_cm = doc
            .descendants()
            .find(|n| n.has_tag_name("distLSB_"))
            .and_then(|n| n.text())
            .map(|t| t.trim().parse::<f64>())
            .transpose()
            .map_err(|e| CalibError::Format(format!("<distLSB_>: {e}")))?
            .unwrap_or(0.2);
        let mut lasers = Calibration::nominal().lasers;
        let mut seen = [false; LASERS];
        for px in doc.descendants().filter(|n| n.has_tag_name("px")) {
            let id = num(px, "id_")?;
            if !(0.0..64.0).contains(&id) || id.fract() != 0.0 {
                return Err(CalibError::Format(format!("laser id {id} is not 0..64")));
            }
            let id = id as usize;
            if id >= LASERS {
                continue;
            }
            if seen[id] {
                return Err(CalibError::Format(format!("laser {id} appears twice")));
            }
            for tag in [
                "distCorrectionX_",
                "distCorrectionY_",
                "focalDistance_",
                "focalSlope_",
            ] {
                if px.children().any(|c| c.has_tag_name(tag)) && num(px, tag)? != 0.0 {
                    return Err(CalibError::Format(format!(
                        "laser {id}: <{tag}> is an HDL-64 correction and must be 0 for the HDL-32E"
                    )));
                }
            }
            lasers[id] = LaserCal {
                vert_deg: num(px, "vertCorrection_")?,
                rot_deg: num(px, "rotCorrection_")?,
                dist_correction_m: num(px, "distCorrection_")? * 0.01,
                vert_offset_m: num(px, "vertOffsetCorrection_")? * 0.01,
                horiz_offset_m: num(px, "horizOffsetCorrection_")? * 0.01,
            };
            seen[id] = true;
        }
        if let Some(missing) = seen.iter().position(|s| !s) {
            return Err(CalibError::Format(format!("laser {missing} is missing")));
        }
        Self::checked(lasers, lsb_cm * 0.01)
    }

    /// The ROS velodyne driver's YAML (`lasers:` list, angles in radians,
    /// distances in metres).
    pub fn from_ros_yaml(text: &str) -> Result<Self, CalibError> {
        let docs = yaml_rust2::YamlLoader::load_from_str(text)
            .map_err(|e| CalibError::Format(format!("not YAML: {e}")))?;
        let doc = docs
            .first()
            .ok_or_else(|| CalibError::Format("empty YAML".into()))?;
        let list = doc["lasers"]
            .as_vec()
            .ok_or_else(|| CalibError::Format("no `lasers:` list".into()))?;
        let f = |y: &yaml_rust2::Yaml, key: &str, id: usize| -> Result<f64, CalibError> {
            match &y[key] {
                yaml_rust2::Yaml::Real(_) | yaml_rust2::Yaml::Integer(_) => Ok(y[key]
                    .as_f64()
                    .or_else(|| y[key].as_i64().map(|i| i as f64))
                    .unwrap_or(0.0)),
                yaml_rust2::Yaml::BadValue => Ok(0.0),
                other => Err(CalibError::Format(format!(
                    "laser {id}: `{key}` is not a number ({other:?})"
                ))),
            }
        };
        let mut lasers = Calibration::nominal().lasers;
        let mut seen = [false; LASERS];
        for y in list {
            let id = y["laser_id"]
                .as_i64()
                .ok_or_else(|| CalibError::Format("a laser has no `laser_id`".into()))?;
            let id = usize::try_from(id)
                .ok()
                .filter(|i| *i < LASERS)
                .ok_or_else(|| CalibError::Format(format!("laser_id {id} is not 0..32")))?;
            if seen[id] {
                return Err(CalibError::Format(format!("laser {id} appears twice")));
            }
            for key in [
                "dist_correction_x",
                "dist_correction_y",
                "focal_distance",
                "focal_slope",
            ] {
                if f(y, key, id)? != 0.0 {
                    return Err(CalibError::Format(format!(
                        "laser {id}: `{key}` is an HDL-64 correction and must be 0 for the HDL-32E"
                    )));
                }
            }
            lasers[id] = LaserCal {
                vert_deg: f(y, "vert_correction", id)?.to_degrees(),
                rot_deg: f(y, "rot_correction", id)?.to_degrees(),
                dist_correction_m: f(y, "dist_correction", id)?,
                vert_offset_m: f(y, "vert_offset_correction", id)?,
                horiz_offset_m: f(y, "horiz_offset_correction", id)?,
            };
            seen[id] = true;
        }
        if let Some(missing) = seen.iter().position(|s| !s) {
            return Err(CalibError::Format(format!("laser {missing} is missing")));
        }
        let lsb = doc["distance_resolution"].as_f64().unwrap_or(0.002);
        Self::checked(lasers, lsb)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(name: &str) -> Option<std::path::PathBuf> {
        crate::shared_data::path(&format!("velodyne/{name}"))
    }

    #[test]
    fn nominal_rings_run_from_the_lowest_beam() {
        let c = Calibration::nominal();
        assert_eq!(c.ring[0], 0);
        assert_eq!(c.ring[1], 16);
        assert_eq!(c.ring[31], 31);
        assert_eq!(c.ring[2], 1);
    }

    #[test]
    fn veloview_xml_and_ros_yaml_match_the_nominal_table() {
        let (Some(xml), Some(yaml)) = (data("HDL-32.xml"), data("32db.yaml")) else {
            return;
        };
        let nominal = Calibration::nominal();
        for c in [
            Calibration::load(&xml).expect("xml"),
            Calibration::load(&yaml).expect("yaml"),
        ] {
            assert!((c.distance_lsb_m - 0.002).abs() < 1e-12);
            assert_eq!(c.ring, nominal.ring);
            for (a, b) in c.lasers.iter().zip(nominal.lasers.iter()) {
                assert!((a.vert_deg - b.vert_deg).abs() < 1e-5, "{a:?} {b:?}");
                assert_eq!(a.rot_deg, 0.0);
            }
        }
    }

    #[test]
    fn broken_files_are_refused_with_reasons() {
        assert!(Calibration::from_veloview_xml("<DB>").is_err());
        assert!(Calibration::from_ros_yaml("lasers: 3").is_err());
        let e = Calibration::from_ros_yaml("lasers:\n- {laser_id: 40}\n").expect_err("id");
        assert!(e.to_string().contains("40"), "{e}");
        let e = Calibration::from_ros_yaml("lasers:\n- {laser_id: 0, vert_correction: 0.1}\n")
            .expect_err("missing lasers");
        assert!(e.to_string().contains("laser 1 is missing"), "{e}");
    }
}
