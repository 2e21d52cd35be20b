//! `--plot OUT.png`: the explored map and the rover's track, seen from
//! above and from the side (x against height), on one scale.
//!
//! Ground the rover can drive is light grey, the border it explored toward
//! light blue, obstacles dark grey; the SLAM keyframe track is red, the
//! true track (simulation) black, home a green disc.

use std::io::BufWriter;
use std::path::Path;

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
    pub patches: Vec<([f64; 3], PatchShade)>,
    pub track: Vec<[f64; 3]>,
    pub truth: Vec<[f64; 3]>,
    pub home: Option<[f64; 3]>,
}

const WIDTH: usize = 1600;
const MAX_HEIGHT: usize = 1600;
const MARGIN: usize = 20;
const GAP: usize = 20;

struct Canvas {
    w: usize,
    h: usize,
    rgb: Vec<u8>,
}

impl Canvas {
    fn put(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h {
            let i = 3 * (y as usize * self.w + x as usize);
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    fn dot(&mut self, x: i64, y: i64, r: i64, c: [u8; 3]) {
        for dy in -r..=r {
            for dx in -r..=r {
                if dx * dx + dy * dy <= r * r {
                    self.put(x + dx, y + dy, c);
                }
            }
        }
    }

    fn line(&mut self, a: (i64, i64), b: (i64, i64), r: i64, c: [u8; 3]) {
        let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).max(1);
        for k in 0..=n {
            let x = a.0 + (b.0 - a.0) * k / n;
            let y = a.1 + (b.1 - a.1) * k / n;
            if r == 0 {
                self.put(x, y, c);
            } else {
                self.dot(x, y, r, c);
            }
        }
    }
}

/// Draw `d` and write it as a PNG.
pub fn write_plot(path: &Path, d: &PlotData) -> Result<(), Error> {
    let all = || {
        d.patches
            .iter()
            .map(|p| p.0)
            .chain(d.track.iter().copied())
            .chain(d.truth.iter().copied())
            .chain(d.home)
    };
    if all().next().is_none() {
        return Err("nothing to plot: no map and no track".into());
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in all() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let span = |k: usize| (hi[k] - lo[k]).max(1.0);
    let usable = (WIDTH - 2 * MARGIN) as f64;
    // One scale for both views, small enough for both to fit.
    let tall = (MAX_HEIGHT - 2 * MARGIN - GAP) as f64;
    let scale = (usable / span(0)).min(tall / (span(1) + span(2)));
    let top_h = (span(1) * scale).ceil() as usize;
    let side_h = (span(2) * scale).ceil() as usize;
    let h = 2 * MARGIN + GAP + top_h + side_h;
    let mut c = Canvas {
        w: WIDTH,
        h,
        rgb: vec![255; WIDTH * h * 3],
    };
    let px = |x: f64| (MARGIN as f64 + (x - lo[0]) * scale).round() as i64;
    // Above: north (+y) up. Beside: up is up.
    let top = |p: [f64; 3]| {
        (
            px(p[0]),
            (MARGIN as f64 + (hi[1] - p[1]) * scale).round() as i64,
        )
    };
    let side_top = (MARGIN + top_h + GAP) as f64;
    let side = |p: [f64; 3]| (px(p[0]), (side_top + (hi[2] - p[2]) * scale).round() as i64);
    let cell = ((0.1 * scale / 2.0).ceil() as i64).max(0);
    // Obstacles last, over the ground.
    for pass in [PatchShade::Ground, PatchShade::Border, PatchShade::Obstacle] {
        let colour = match pass {
            PatchShade::Ground => [205, 205, 205],
            PatchShade::Border => [150, 190, 235],
            PatchShade::Obstacle => [90, 90, 90],
        };
        for (p, s) in d.patches.iter().filter(|p| p.1 == pass) {
            let (x, y) = top(*p);
            c.dot(x, y, cell, colour);
            let (x, y) = side(*p);
            c.put(
                x,
                y,
                if *s == PatchShade::Obstacle {
                    colour
                } else {
                    [170; 3]
                },
            );
        }
    }
    for (track, r, colour) in [(&d.truth, 0, [0, 0, 0]), (&d.track, 1, [220, 30, 30])] {
        for w in track.windows(2) {
            c.line(top(w[0]), top(w[1]), r, colour);
            c.line(side(w[0]), side(w[1]), r, colour);
        }
    }
    if let Some(home) = d.home {
        let (x, y) = top(home);
        c.dot(x, y, 6, [30, 160, 60]);
        let (x, y) = side(home);
        c.dot(x, y, 6, [30, 160, 60]);
    }
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut enc = png::Encoder::new(BufWriter::new(file), WIDTH as u32, h as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header()?;
    w.write_image_data(&c.rgb)?;
    w.finish()?;
    Ok(())
}

/// The explored graph and the tracks, in the world frame when the map
/// frame's place in it is known (simulation), else in the map frame.
pub fn of_mission(r: &MissionResult) -> PlotData {
    let (origin, heading) = r.world_from_map.unwrap_or(([0.0; 3], 0.0));
    let (s, c) = heading.sin_cos();
    let to_world = |p: [f64; 3]| {
        [
            origin[0] + c * p[0] - s * p[1],
            origin[1] + s * p[0] + c * p[1],
            origin[2] + p[2],
        ]
    };
    let mut d = PlotData::default();
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
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plot_is_a_png_of_both_views() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("p.png");
        let mut d = PlotData::default();
        for i in 0..200 {
            d.patches
                .push(([i as f64 * 0.1, 0.0, 0.0], PatchShade::Ground));
            d.patches
                .push(([i as f64 * 0.1, 2.0, 0.5], PatchShade::Obstacle));
        }
        d.track = vec![[0.0, 1.0, 0.2], [19.0, 1.0, 0.2]];
        d.home = Some([0.0, 1.0, 0.2]);
        write_plot(&path, &d).unwrap_or_else(|e| panic!("{e}"));
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(&bytes[1..4], b"PNG");
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let r = dec.read_info().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(r.info().width as usize, WIDTH);
        assert!(write_plot(&path, &PlotData::default()).is_err());
    }
}
