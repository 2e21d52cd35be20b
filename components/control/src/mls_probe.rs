//! The safety monitor's view of the multi-level surface map: ground,
//! a drop, nothing seen, or something at body height.

use speleo_mapping::mls::{drop_at, ground_near, MlsMap};

use crate::{GroundProbe, Probe};

/// Log the cell where the probe that made a map stop looked: its patch
/// count, the lowest patch's top and the highest one's bottom (cm), and
/// whether each was seen from above. Short, whole centimetres: the patch
/// list formatted whole, and then its floats, ran past the log line's
/// buffer, which grew, and the control task allocated after start-up.
pub(crate) fn log_probe_cell(map: &MlsMap, x: f64, y: f64) {
    let cm = |v: f64| (v * 100.0).round() as i32;
    let (ix, iy) = map.cell_of(x, y);
    let cell = map.cell(ix, iy);
    let (Some(lo), Some(hi)) = (cell.first(), cell.last()) else {
        tracing::debug!(x_cm = cm(x), y_cm = cm(y), patches = 0, "safety stop probe");
        return;
    };
    tracing::debug!(
        x_cm = cm(x),
        y_cm = cm(y),
        patches = cell.len(),
        low_top_cm = cm(lo.max.into()),
        low_above = lo.seen_from_above,
        high_bottom_cm = cm(hi.min.into()),
        high_above = hi.seen_from_above,
        "safety stop probe"
    );
}

/// The MLS map as the safety monitor probes it.
pub struct MlsProbe<'a>(pub &'a MlsMap);

/// Height band over the ground that the body sweeps, m: anything in it
/// blocks but a stray return seen from below ([`Patch::stray_from_below`];
/// the planner, which counts every point, draws the next plan).
///
/// [`Patch::stray_from_below`]: speleo_mapping::mls::Patch::stray_from_below
const BODY_BAND_M: (f32, f32) = (0.25, 0.7);

impl GroundProbe for MlsProbe<'_> {
    fn probe(&self, x: f64, y: f64, z: f64, tol_m: f64) -> Probe {
        let (ix, iy) = self.0.cell_of(x, y);
        let cell = self.0.cell(ix, iy);
        let Some(g) = ground_near(cell, z as f32, tol_m as f32) else {
            if drop_at(cell, z as f32, tol_m as f32) {
                return Probe::Drop;
            }
            return Probe::NoGround;
        };
        let (lo, hi) = (g + BODY_BAND_M.0, g + BODY_BAND_M.1);
        if cell
            .iter()
            .any(|p| !p.stray_from_below() && p.max >= lo && p.min <= hi)
        {
            Probe::Blocked
        } else {
            Probe::Ground
        }
    }
}
