//! Where the side branch joins the main tube. Each tube keeps its surface
//! only outside the other's inside (a union by culling quads on their
//! centres), so the main wall opens where the branch leaves and no part of
//! the branch stands inside the main tube: its first rings cross the main
//! tube diagonally, and a rover driving past climbed their walls and tipped
//! over.

use super::{Station, FLOOR_CUT, STEP_M};

/// The inside of a tube near some of its stations.
pub(super) struct TubeVolume<'a> {
    stations: &'a [Station],
    /// The tube is open before its first station (a branch's start): only
    /// points beyond that station's plane are inside.
    open_start: bool,
}

/// A point in the cross-section of a station: lateral (left), vertical
/// (from the centre) and along the heading, m.
struct Section {
    h: f64,
    v: f64,
    along: f64,
}

fn section(st: &Station, p: [f64; 3]) -> Section {
    let (sh, ch) = (libm::sin(st.heading), libm::cos(st.heading));
    let (dx, dy) = (p[0] - st.c[0], p[1] - st.c[1]);
    Section {
        h: -sh * dx + ch * dy,
        v: p[2] - st.c[2],
        along: ch * dx + sh * dy,
    }
}

impl<'a> TubeVolume<'a> {
    pub(super) fn new(stations: &'a [Station], open_start: bool) -> Self {
        TubeVolume {
            stations,
            open_start,
        }
    }

    /// The section of `p` at its nearest station, if that station's slab
    /// holds it (not beyond the ends of the stations given).
    fn locate(&self, p: [f64; 3]) -> Option<(Section, f64)> {
        let d2 = |st: &Station| {
            (0..3)
                .map(|i| (p[i] - st.c[i]) * (p[i] - st.c[i]))
                .sum::<f64>()
        };
        let st = self
            .stations
            .iter()
            .min_by(|a, b| d2(a).total_cmp(&d2(b)))?;
        if self.open_start && section(&self.stations[0], p).along <= 0.0 {
            return None;
        }
        let s = section(st, p);
        (s.along.abs() <= STEP_M).then_some((s, st.radius))
    }

    /// Inside the tube's ellipse, above its floor.
    pub(super) fn holds(&self, p: [f64; 3]) -> bool {
        self.locate(p).is_some_and(|(s, r)| {
            let rv = 0.85 * r;
            s.v > -FLOOR_CUT * rv && in_ellipse(&s, r)
        })
    }

    /// Inside the whole ellipse, also below the floor: the branch's walls
    /// there would stick through the main floor.
    pub(super) fn holds_uncut(&self, p: [f64; 3]) -> bool {
        self.locate(p).is_some_and(|(s, r)| in_ellipse(&s, r))
    }

    /// Above or below the floor, within its width: the branch's floor is
    /// left out there, so the main floor alone carries the rover.
    pub(super) fn over_floor(&self, p: [f64; 3]) -> bool {
        self.locate(p).is_some_and(|(s, r)| {
            let half_width = r * (1.0 - FLOOR_CUT * FLOOR_CUT).sqrt();
            s.h.abs() < half_width && s.v.abs() < 0.85 * r
        })
    }
}

fn in_ellipse(s: &Section, r: f64) -> bool {
    let (rh, rv) = (r, 0.85 * r);
    (s.h / rh).powi(2) + (s.v / rv).powi(2) < 1.0
}
