//! `campaign report --plot OUT.png`: a campaign's outcomes at a glance.
//! One panel a world, its floor seen from above with a marker where each
//! mission ended, coloured by its outcome; then the whole-cave missions'
//! coverage as a histogram, passed and failed stacked. Axes in metres,
//! titles and a legend on every panel.

use std::collections::BTreeMap;
use std::path::Path;

use crate::chart::{tick_step, Alignment, Chart, Colour as Rgb888, Point, Size, BLACK, GRID};

use crate::success::FailureCause;
use crate::summary::{CaseRow, Summary};

/// A world's floor seen from above: points of ground, world frame, m.
pub struct FloorMap {
    /// The panel's title (world and seed).
    pub title: String,
    pub floor: Vec<[f64; 2]>,
    /// The side of the floor's cells, m.
    pub floor_cell_m: f64,
    /// The cases ended in this world (their ids).
    pub cases: Vec<usize>,
}

const WIDTH: u32 = 1600;
const MARGIN_L: i32 = 70;
const MARGIN_R: i32 = 30;
const PANEL_GAP: i32 = 70;
const MAP_MAX_H: i32 = 420;
const MAP_MIN_H: i32 = 140;
const HIST_H: i32 = 320;

const FLOOR: Rgb888 = Rgb888::new(205, 205, 205);
const PASSED: Rgb888 = Rgb888::new(30, 150, 60);

/// A failure's colour on the map and in the legend.
fn cause_colour(c: FailureCause) -> Rgb888 {
    match c {
        FailureCause::Crash | FailureCause::Hang => Rgb888::new(120, 120, 120),
        FailureCause::Fall => Rgb888::new(140, 40, 160),
        FailureCause::Collision => Rgb888::new(230, 120, 0),
        FailureCause::Stranded => Rgb888::new(215, 30, 30),
        FailureCause::OutOfTime => Rgb888::new(30, 90, 210),
        FailureCause::NotHome => Rgb888::new(0, 170, 190),
        FailureCause::GaveUpEarly => Rgb888::new(200, 170, 0),
    }
}

/// Where a row ended and how, for its marker.
fn outcome_colour(r: &CaseRow) -> Option<Rgb888> {
    r.status?;
    Some(r.failure.map_or(PASSED, cause_colour))
}

/// Draws the plot and writes it as PNG.
pub fn write_plot(path: &Path, s: &Summary, maps: &[FloorMap]) -> Result<(), String> {
    // Each map keeps its aspect at the plot's width.
    let inner_w = WIDTH as i32 - MARGIN_L - MARGIN_R;
    let extents: Vec<Option<[f64; 4]>> = maps.iter().map(|m| extent(m, s)).collect();
    let heights: Vec<i32> = extents
        .iter()
        .map(|e| {
            e.map_or(MAP_MIN_H, |[x0, x1, y0, y1]| {
                ((inner_w as f64 * (y1 - y0) / (x1 - x0).max(1e-6)) as i32)
                    .clamp(MAP_MIN_H, MAP_MAX_H)
            })
        })
        .collect();
    let h = 60 + heights.iter().map(|h| h + PANEL_GAP + 20).sum::<i32>() + HIST_H + PANEL_GAP + 40;
    let mut c = Chart::new(WIDTH, h as u32);
    c.title(
        &format!(
            "Campaign {}: {} of {} missions succeeded ({:.0} %, 95 % CI {:.0}-{:.0} %){}",
            s.name,
            s.overall.passed,
            s.overall.n,
            100.0 * s.overall.rate,
            100.0 * s.overall.low,
            100.0 * s.overall.high,
            if s.missing > 0 {
                format!("; {} cases not run", s.missing)
            } else {
                String::new()
            }
        ),
        Point::new(MARGIN_L, 25),
    );
    let mut items = vec![(PASSED, "passed".to_string())];
    for f in &s.failures {
        items.push((
            cause_colour(f.cause),
            format!("{} ({})", f.cause.name(), f.cases.len()),
        ));
    }
    c.legend(MARGIN_L, 48, &items);
    let mut top = 60 + PANEL_GAP / 2;
    for ((m, e), ph) in maps.iter().zip(&extents).zip(&heights) {
        draw_map(&mut c, s, m, *e, top, *ph);
        top += ph + PANEL_GAP + 20;
    }
    draw_histogram(&mut c, s, top + 20);
    c.save(path)
}

/// The map's extent (x0, x1, y0, y1) over its floor and its cases' ends.
fn extent(m: &FloorMap, s: &Summary) -> Option<[f64; 4]> {
    let ends = m.cases.iter().filter_map(|&i| s.rows.get(i)?.end_position);
    let pts = m.floor.iter().copied().chain(ends.map(|p| [p[0], p[1]]));
    let mut e: Option<[f64; 4]> = None;
    for [x, y] in pts {
        let v = e.get_or_insert([x, x, y, y]);
        *v = [v[0].min(x), v[1].max(x), v[2].min(y), v[3].max(y)];
    }
    e.map(|[x0, x1, y0, y1]| [x0 - 1.0, x1 + 1.0, y0 - 1.0, y1 + 1.0])
}

fn draw_map(c: &mut Chart, s: &Summary, m: &FloorMap, e: Option<[f64; 4]>, top: i32, ph: i32) {
    c.title(
        &format!("{}: where each mission ended, seen from above", m.title),
        Point::new(MARGIN_L, top - 8),
    );
    let Some([x0, x1, y0, y1]) = e else {
        c.text(
            "(no floor and no ends to draw)",
            Point::new(MARGIN_L, top + 20),
            Alignment::Left,
        );
        return;
    };
    let pw = WIDTH as i32 - MARGIN_L - MARGIN_R;
    // One scale for both axes, so the cave keeps its shape.
    let scale = (pw as f64 / (x1 - x0)).min(ph as f64 / (y1 - y0));
    let to_px = |x: f64, y: f64| {
        Point::new(
            MARGIN_L + ((x - x0) * scale) as i32,
            top + ph - ((y - y0) * scale) as i32,
        )
    };
    let step = tick_step((x1 - x0).max(y1 - y0), 12.0);
    let mut t = (x0 / step).ceil() * step;
    while t <= x1 {
        let p = to_px(t, y0);
        c.line(Point::new(p.x, top), Point::new(p.x, top + ph), GRID, 1);
        c.text(
            &format!("{t:.0}"),
            Point::new(p.x, top + ph + 16),
            Alignment::Center,
        );
        t += step;
    }
    let mut t = (y0 / step).ceil() * step;
    while t <= y1 {
        let p = to_px(x0, t);
        c.line(
            Point::new(MARGIN_L, p.y),
            Point::new(MARGIN_L + pw, p.y),
            GRID,
            1,
        );
        c.text(
            &format!("{t:.0}"),
            Point::new(MARGIN_L - 6, p.y + 4),
            Alignment::Right,
        );
        t += step;
    }
    let dot = (scale * m.floor_cell_m).ceil().max(1.0) as u32;
    let half = m.floor_cell_m / 2.0;
    for &[x, y] in &m.floor {
        // The cell's corner nearest the origin of the picture.
        c.rect(to_px(x - half, y + half), Size::new(dot, dot), FLOOR);
    }
    c.axes((MARGIN_L, top), pw, ph, "x, m", "y, m");
    // Passed first, so a failure is drawn over a success at the same place.
    let mut rows: Vec<&CaseRow> = m.cases.iter().filter_map(|&i| s.rows.get(i)).collect();
    rows.sort_by_key(|r| r.failure.is_some());
    for r in rows {
        if let (Some(col), Some(p)) = (outcome_colour(r), r.end_position) {
            c.marker(to_px(p[0], p[1]), 11, col);
        }
    }
}

fn draw_histogram(c: &mut Chart, s: &Summary, top: i32) {
    c.title(
        "Coverage of the reachable floor, whole-cave missions",
        Point::new(MARGIN_L, top - 8),
    );
    const BINS: usize = 10;
    // Each bin's missions by outcome, stacked passed first, in the
    // legend's colours.
    let mut counts: Vec<BTreeMap<Option<FailureCause>, usize>> = vec![BTreeMap::new(); BINS];
    for r in s
        .rows
        .iter()
        .filter(|r| r.scenario.is_none() && r.status.is_some())
    {
        let Some(v) = r.coverage else { continue };
        let b = ((v * BINS as f64) as usize).min(BINS - 1);
        *counts[b].entry(r.failure).or_default() += 1;
    }
    let most = counts
        .iter()
        .map(|m| m.values().sum::<usize>())
        .max()
        .unwrap_or(0);
    if most == 0 {
        c.text(
            "(no whole-cave mission measured its coverage)",
            Point::new(MARGIN_L, top + 20),
            Alignment::Left,
        );
        return;
    }
    let pw = WIDTH as i32 - MARGIN_L - MARGIN_R;
    let ph = HIST_H;
    let bar_w = pw / BINS as i32;
    let y_of = |n: usize| top + ph - (n as f64 / most as f64 * ph as f64) as i32;
    let step = tick_step(most as f64, 5.0).max(1.0) as usize;
    let mut n = 0;
    while n <= most {
        let y = y_of(n);
        c.line(
            Point::new(MARGIN_L, y),
            Point::new(MARGIN_L + pw, y),
            GRID,
            1,
        );
        c.text(
            &n.to_string(),
            Point::new(MARGIN_L - 6, y + 4),
            Alignment::Right,
        );
        n += step;
    }
    for (b, bin) in counts.iter().enumerate() {
        let x = MARGIN_L + b as i32 * bar_w + 4;
        let mut below = 0;
        // `None` (passed) sorts first.
        for (outcome, &k) in bin {
            let (y_lo, y_hi) = (y_of(below), y_of(below + k));
            let col = outcome.map_or(PASSED, cause_colour);
            c.rect(
                Point::new(x, y_hi),
                Size::new((bar_w - 8) as u32, (y_lo - y_hi) as u32),
                col,
            );
            below += k;
        }
    }
    for b in 0..=BINS {
        let x = MARGIN_L + b as i32 * bar_w;
        c.line(
            Point::new(x, top + ph),
            Point::new(x, top + ph + 5),
            BLACK,
            1,
        );
        c.text(
            &format!("{:.1}", b as f64 / BINS as f64),
            Point::new(x, top + ph + 18),
            Alignment::Center,
        );
    }
    c.axes((MARGIN_L, top), pw, ph, "coverage", "missions");
    c.text(
        "colours as in the legend at the top",
        Point::new(MARGIN_L + pw, top - 8),
        Alignment::Right,
    );
}

/// Groups the campaign's cases by world and world seed, for one map each.
pub fn cases_by_world(s: &Summary) -> BTreeMap<(String, u64), Vec<usize>> {
    let mut m: BTreeMap<(String, u64), Vec<usize>> = BTreeMap::new();
    for r in &s.rows {
        m.entry((r.world.clone(), r.world_seed))
            .or_default()
            .push(r.id);
    }
    m
}
