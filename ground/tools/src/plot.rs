//! `--plot OUT.png|OUT.svg`: the explored map and the rover's track, seen
//! from above and from the side (x against height), on one scale, with
//! axes in metres, a scale bar, a legend and a title naming the mission.
//!
//! Ground the rover can drive is light grey, the border it explored toward
//! light blue, obstacles dark grey; the SLAM keyframe track is red, the
//! true track (simulation) black, home a green disc, and where a stranded
//! rover ended a purple one.

use std::path::Path;

use speleo_campaign::chart::{tick_step, Alignment, Chart, Colour, Point, Size, BLACK, GRID};
use speleo_firmware::mission::MissionResult;
use speleo_traversability::TravClass;

use crate::Error;

/// What a map patch is, for its colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PatchShade {
    Ground,
    Border,
    Obstacle,
}

/// What to draw; every position in one frame.
#[derive(Default)]
pub struct PlotData {
    /// The first line of the title (the world and seeds).
    pub title: String,
    /// The second: what the mission did.
    pub subtitle: String,
    pub patches: Vec<([f64; 3], PatchShade)>,
    pub track: Vec<[f64; 3]>,
    pub truth: Vec<[f64; 3]>,
    pub home: Option<[f64; 3]>,
    /// Where the rover ended when it was stranded.
    pub stranded: Option<[f64; 3]>,
}

const WIDTH: u32 = 1600;
const MARGIN_L: i32 = 70;
const MARGIN_R: i32 = 30;
/// Above the first panel: title, subtitle and legend.
const HEADER: i32 = 120;
/// Between the panels, for the tick labels and the next panel's title.
const PANEL_GAP: i32 = 80;
const MAX_PANELS_H: f64 = 1300.0;
const MIN_PANEL_H: i32 = 60;

const GROUND: Colour = Colour::new(205, 205, 205);
const BORDER: Colour = Colour::new(150, 190, 235);
const OBSTACLE: Colour = Colour::new(90, 90, 90);
const SLAM: Colour = Colour::new(220, 30, 30);
const HOME: Colour = Colour::new(30, 160, 60);
const STRANDED: Colour = Colour::new(140, 40, 160);

/// One view: which coordinates go across and up, and its place.
struct Panel {
    title: &'static str,
    across: usize,
    up: usize,
    top: i32,
    height: i32,
}

/// Draw `d` and write it as PNG or SVG (by `path`'s extension).
pub fn write_plot(path: &Path, d: &PlotData) -> Result<(), Error> {
    let all = || {
        d.patches
            .iter()
            .map(|p| p.0)
            .chain(d.track.iter().copied())
            .chain(d.truth.iter().copied())
            .chain(d.home)
            .chain(d.stranded)
    };
    if all().next().is_none() {
        return Err("nothing to plot: no map and no track".into());
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in all() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k] - 1.0);
            hi[k] = hi[k].max(p[k] + 1.0);
        }
    }
    let span = |k: usize| hi[k] - lo[k];
    let pw = WIDTH as i32 - MARGIN_L - MARGIN_R;
    // One scale for both views, small enough for both to fit.
    let scale = (pw as f64 / span(0)).min(MAX_PANELS_H / (span(1) + span(2)));
    let above_h = ((span(1) * scale).ceil() as i32).max(MIN_PANEL_H);
    let side_h = ((span(2) * scale).ceil() as i32).max(MIN_PANEL_H);
    let panels = [
        Panel {
            title: "Seen from above",
            across: 0,
            up: 1,
            top: HEADER,
            height: above_h,
        },
        Panel {
            title: "Seen from the side",
            across: 0,
            up: 2,
            top: HEADER + above_h + PANEL_GAP,
            height: side_h,
        },
    ];
    let h = HEADER + above_h + PANEL_GAP + side_h + 50;
    let mut c = Chart::new(WIDTH, h as u32);
    c.title(&d.title, Point::new(MARGIN_L, 25));
    c.text(&d.subtitle, Point::new(MARGIN_L, 45), Alignment::Left);
    let mut items = vec![
        (GROUND, "explored floor".to_string()),
        (BORDER, "border toward the unexplored".to_string()),
        (OBSTACLE, "obstacle".to_string()),
        (SLAM, "track (SLAM keyframes)".to_string()),
    ];
    if !d.truth.is_empty() {
        items.push((BLACK, "true track".to_string()));
    }
    items.push((HOME, "start and home".to_string()));
    if d.stranded.is_some() {
        items.push((STRANDED, "stranded".to_string()));
    }
    c.legend(MARGIN_L, 72, &items);
    let step = tick_step(span(0).max(span(1)), 12.0);
    for p in &panels {
        draw_panel(&mut c, d, p, (lo, hi), scale, step);
    }
    c.save(path)?;
    Ok(())
}

fn draw_panel(
    c: &mut Chart,
    d: &PlotData,
    p: &Panel,
    (lo, hi): ([f64; 3], [f64; 3]),
    scale: f64,
    step: f64,
) {
    let pw = WIDTH as i32 - MARGIN_L - MARGIN_R;
    let (a, u) = (p.across, p.up);
    let at = |q: [f64; 3]| {
        Point::new(
            MARGIN_L + ((q[a] - lo[a]) * scale).round() as i32,
            p.top + p.height - ((q[u] - lo[u]) * scale).round() as i32,
        )
    };
    c.title(p.title, Point::new(MARGIN_L, p.top - 28));
    // Grid and tick labels every `step` metres on both axes (one scale).
    let mut t = (lo[a] / step).ceil() * step;
    while t <= hi[a] {
        let x = MARGIN_L + ((t - lo[a]) * scale).round() as i32;
        c.line(
            Point::new(x, p.top),
            Point::new(x, p.top + p.height),
            GRID,
            1,
        );
        c.text(
            &metres(t),
            Point::new(x, p.top + p.height + 16),
            Alignment::Center,
        );
        t += step;
    }
    let mut t = (lo[u] / step).ceil() * step;
    while t <= hi[u] {
        let y = p.top + p.height - ((t - lo[u]) * scale).round() as i32;
        if y >= p.top {
            c.line(
                Point::new(MARGIN_L, y),
                Point::new(MARGIN_L + pw, y),
                GRID,
                1,
            );
            c.text(
                &metres(t),
                Point::new(MARGIN_L - 6, y + 4),
                Alignment::Right,
            );
        }
        t += step;
    }
    let cell = ((0.1 * scale).ceil() as u32).max(1);
    let half = cell as i32 / 2;
    // Obstacles last, over the ground.
    for (shade, colour) in [
        (PatchShade::Ground, GROUND),
        (PatchShade::Border, BORDER),
        (PatchShade::Obstacle, OBSTACLE),
    ] {
        for (q, _) in d.patches.iter().filter(|x| x.1 == shade) {
            let m = at(*q);
            c.rect(m - Point::new(half, half), Size::new(cell, cell), colour);
        }
    }
    for (track, width, colour) in [(&d.truth, 1, BLACK), (&d.track, 2, SLAM)] {
        for w in track.windows(2) {
            c.line(at(w[0]), at(w[1]), colour, width);
        }
    }
    if let Some(home) = d.home {
        c.marker(at(home), 13, HOME);
    }
    if let Some(end) = d.stranded {
        c.marker(at(end), 13, STRANDED);
    }
    c.axes(
        (MARGIN_L, p.top),
        pw,
        p.height,
        "x, m",
        ["x, m", "y, m", "z, m"][u],
    );
    // A scale bar in the panel's lower right corner.
    let bar = (step * scale).round() as i32;
    let (x1, y) = (MARGIN_L + pw - 10, p.top + p.height - 10);
    c.line(Point::new(x1 - bar, y), Point::new(x1, y), BLACK, 3);
    c.text(
        &format!("{} m", metres(step)),
        Point::new(x1 - bar / 2, y - 6),
        Alignment::Center,
    );
}

/// A tick's value: whole metres, or one decimal below 1 m steps.
fn metres(v: f64) -> String {
    // Rounded to the decimal shown; adding zero turns -0.0 into 0.0.
    let v = (v * 10.0).round() / 10.0 + 0.0;
    if (v - v.round()).abs() < 1e-6 {
        format!("{v:.0}")
    } else {
        format!("{v:.1}")
    }
}

/// The explored graph and the tracks, in the world frame when the map
/// frame's place in it is known (simulation), else in the map frame.
pub fn of_mission(r: &MissionResult, title: String) -> PlotData {
    let (origin, heading) = r.world_from_map.unwrap_or(([0.0; 3], 0.0));
    let (s, c) = heading.sin_cos();
    let to_world = |p: [f64; 3]| {
        [
            origin[0] + c * p[0] - s * p[1],
            origin[1] + s * p[0] + c * p[1],
            origin[2] + p[2],
        ]
    };
    let mut d = PlotData {
        title,
        subtitle: subtitle(r),
        ..PlotData::default()
    };
    if let Some(t) = &r.explored {
        for n in t.nodes() {
            let shade = match n.class {
                TravClass::Traversable => PatchShade::Ground,
                TravClass::Explorable | TravClass::Frontier => PatchShade::Border,
                TravClass::Obstacle | TravClass::Unknown => PatchShade::Obstacle,
            };
            d.patches.push((to_world(t.position(n)), shade));
        }
    }
    if let Some(slam) = &r.slam {
        // SLAM puts its keyframes in the world frame when it knows it.
        d.track = slam.trajectory.iter().map(|k| k.position).collect();
        d.truth = slam
            .trajectory
            .iter()
            .filter_map(|k| k.truth.map(|t| t.0))
            .collect();
    }
    d.home = r.exploration_home.map(to_world);
    if let Some(e) = r.exploration.as_ref().filter(|e| e.state == "stranded") {
        d.stranded = e.end_position;
    }
    d
}

/// What the mission did, in one line.
fn subtitle(r: &MissionResult) -> String {
    let mut parts = vec![format!("{:.0} s of mission", r.sim_time_s)];
    if let Some(e) = &r.exploration {
        parts.push(e.state.clone());
        if let Some(c) = e.coverage_fraction {
            parts.push(format!("coverage {c:.2}"));
        }
        if let Some(d) = e.distance_m {
            parts.push(format!("{d:.0} m driven"));
        }
        if let Some(h) = e.home_error_m.filter(|_| e.returned_home) {
            parts.push(format!("home within {h:.2} m"));
        }
    }
    parts.push(format!("output hash {:016x}", r.output_hash));
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> PlotData {
        let mut d = PlotData {
            title: "world flat, seed 1".into(),
            subtitle: "20 s of mission".into(),
            ..PlotData::default()
        };
        for i in 0..200 {
            d.patches
                .push(([i as f64 * 0.1, 0.0, 0.0], PatchShade::Ground));
            d.patches
                .push(([i as f64 * 0.1, 2.0, 0.5], PatchShade::Obstacle));
        }
        d.track = vec![[0.0, 1.0, 0.2], [19.0, 1.0, 0.2]];
        d.home = Some([0.0, 1.0, 0.2]);
        d.stranded = Some([19.0, 1.0, 0.2]);
        d
    }

    #[test]
    fn a_plot_is_a_png_or_an_svg_of_both_views_with_title_and_legend() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("p.png");
        write_plot(&path, &sample()).unwrap_or_else(|e| panic!("{e}"));
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(&bytes[1..4], b"PNG");
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let r = dec.read_info().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(r.info().width, WIDTH);
        let svg = dir.path().join("p.svg");
        write_plot(&svg, &sample()).unwrap_or_else(|e| panic!("{e}"));
        let text = std::fs::read_to_string(&svg).unwrap_or_else(|e| panic!("{e}"));
        for s in [
            "world flat, seed 1",
            "Seen from above",
            "Seen from the side",
            "explored floor",
            "stranded",
            "x, m",
            "z, m",
        ] {
            assert!(text.contains(s), "no {s:?} in the SVG");
        }
        assert!(write_plot(&path, &PlotData::default()).is_err());
    }

    #[test]
    fn tick_labels_are_metres_without_a_negative_zero() {
        assert_eq!(metres(-1e-12), "0");
        assert_eq!(metres(-4.0), "-4");
        assert_eq!(metres(0.5), "0.5");
    }
}
