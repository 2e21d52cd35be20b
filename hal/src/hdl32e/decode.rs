//! Data packets to points.
//!
//! Each laser of a block fires `l * 1.152 us` after the block's first laser,
//! so its azimuth is interpolated between this block's azimuth and the next
//! one's (`az + delta * l / 40`); the last block of a packet reuses the
//! previous block's step. Points are in the ROS convention (x forward, y left,
//! z up): `x = r cos(el) cos(az)`, `y = -r cos(el) sin(az)`.
//!
//! Speed: the sine and cosine of each block's azimuth are computed once; the
//! small per-laser step is added with a fifth-order Taylor expansion (exact
//! to 1e-13 for steps under 0.01 rad) and the rotational correction with a
//! precomputed angle sum, so a point costs a handful of multiplications.

use super::calib::Calibration;
use super::packet::DataPacket;
use super::{BLOCKS, BLOCK_PERIOD_NS, LASERS, LASER_PERIOD_NS};

/// One return.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Point {
    pub x: f32,
    pub y: f32,
    pub z: f32,
    /// Seconds after the first firing of the packet (or of the frame, once
    /// assembled into one).
    pub time: f32,
    pub distance: f32,
    /// Interpolated azimuth of the firing, degrees in [0, 360).
    pub azimuth: f32,
    pub intensity: u8,
    /// 0 = lowest beam.
    pub ring: u8,
    pub laser: u8,
    /// Block of the packet the point came from.
    pub block: u8,
    /// In a dual-return packet, which block of the pair (0 or 1); else 0.
    pub return_index: u8,
}

#[derive(Clone, Copy, Debug, Default)]
struct LaserK {
    cos_v: f64,
    sin_v: f64,
    cos_r: f64,
    sin_r: f64,
    dist_corr: f64,
    vert_off: f64,
    horiz_off: f64,
    ring: u8,
    /// Fraction of a block period after the block's first firing.
    frac: f64,
}

/// How the azimuth of each laser within a block is found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Interpolation {
    /// From this block's azimuth toward the next block's, by firing time,
    /// without rounding (the last block reuses the previous step).
    #[default]
    Continuous,
    /// VeloView's HDL-32 reader: one step per packet (the 7th smallest of
    /// the 11 block-to-block steps), each laser's offset rounded to whole
    /// hundredths of a degree and looked up in 0.01 deg sine/cosine tables.
    /// For comparisons with VeloView output.
    VeloView,
    /// velodyne-decoder 3.1 (PyPI): a fixed offset of 0.01 deg per laser
    /// pair (`floor(l / 2)` hundredths), whatever the block step. For
    /// comparisons with its output.
    FixedPairs,
}

/// Decodes packets with one calibration.
#[derive(Clone, Debug)]
pub struct Decoder {
    lasers: [LaserK; LASERS],
    lsb: f64,
    /// Minimum distance kept, metres (closer returns are dropped).
    pub min_distance_m: f64,
    /// Also emit returns with distance 0 (no return) as points at the
    /// origin carrying their intensity, so a packet can be rebuilt exactly.
    pub keep_empty: bool,
    mode: Interpolation,
    /// VeloView's tables: (sin, cos) of i / 100 degrees, i in 0..=36000.
    tables: Option<Box<[(f64, f64)]>>,
}

const HUNDREDTH_RAD: f64 = core::f64::consts::PI / 18000.0;
/// Largest believable azimuth step between firings (3 deg; 0.4 deg at the
/// top speed of 20 Hz). A larger one comes from a damaged or reordered
/// block: the laser azimuths are then not interpolated.
pub const MAX_STEP_HUNDREDTHS: u32 = 300;

/// Azimuth step from `a` to `b` in hundredths of a degree, across the wrap.
#[inline]
pub fn azimuth_step(a: u16, b: u16) -> u32 {
    (b as u32 + 36000 - a as u32) % 36000
}

impl Decoder {
    pub fn new(cal: &Calibration) -> Self {
        let mut lasers = [LaserK::default(); LASERS];
        for (i, (k, c)) in lasers.iter_mut().zip(cal.lasers.iter()).enumerate() {
            let (sv, cv) = c.vert_deg.to_radians().sin_cos();
            let (sr, cr) = c.rot_deg.to_radians().sin_cos();
            *k = LaserK {
                cos_v: cv,
                sin_v: sv,
                cos_r: cr,
                sin_r: sr,
                dist_corr: c.dist_correction_m,
                vert_off: c.vert_offset_m,
                horiz_off: c.horiz_offset_m,
                ring: cal.ring[i],
                frac: i as f64 * LASER_PERIOD_NS / BLOCK_PERIOD_NS,
            };
        }
        Decoder {
            lasers,
            lsb: cal.distance_lsb_m,
            min_distance_m: 0.0,
            keep_empty: false,
            mode: Interpolation::Continuous,
            tables: None,
        }
    }

    /// Choose the interpolation (see [`Interpolation`]).
    pub fn with_interpolation(mut self, mode: Interpolation) -> Self {
        self.mode = mode;
        self.tables = match mode {
            Interpolation::Continuous | Interpolation::FixedPairs => None,
            Interpolation::VeloView => Some(
                (0..=36000)
                    .map(|i| {
                        // toRadians(i / 100.0) = x * pi / 180, in that order.
                        let r = (i as f64 / 100.0) * core::f64::consts::PI / 180.0;
                        (r.sin(), r.cos())
                    })
                    .collect(),
            ),
        };
        self
    }

    pub fn interpolation(&self) -> Interpolation {
        self.mode
    }

    /// VeloView's per-packet azimuth step: the 7th smallest of the 11 steps.
    pub fn veloview_step(p: &DataPacket) -> u32 {
        let mut d = [0u32; BLOCKS - 1];
        for (b, s) in d.iter_mut().enumerate() {
            *s = azimuth_step(p.blocks[b].azimuth, p.blocks[b + 1].azimuth);
        }
        d.sort_unstable();
        d[BLOCKS / 2]
    }

    /// VeloView's rounded offset (hundredths) of laser `l` in block `b`,
    /// with its floating-point operations in its order.
    fn veloview_offset(step: u32, b: usize, l: usize) -> u32 {
        let t = |block: usize, laser: usize| block as f64 * 46.08 + laser as f64 * 1.152;
        let block0 = t(b, 0);
        let f = step as f64 * ((t(b, l) - block0) / (t(b + 1, 0) - block0));
        (f + 0.5) as u32
    }

    fn decode_veloview(&self, p: &DataPacket, tables: &[(f64, f64)], f: &mut impl FnMut(Point)) {
        let step = Self::veloview_step(p);
        for (b, blk) in p.blocks.iter().enumerate() {
            let t_block = b as f64 * BLOCK_PERIOD_NS * 1e-9;
            for l in 0..LASERS {
                let Some(dist) = self.distance(blk, b, l, f) else {
                    continue;
                };
                let k = &self.lasers[l];
                let az = (blk.azimuth as u32 + Self::veloview_offset(step, b, l)) % 36000;
                let (s_az, c_az) = tables[az as usize];
                let (sphi, cphi) = if k.sin_r == 0.0 {
                    (s_az, c_az)
                } else {
                    (
                        s_az * k.cos_r - c_az * k.sin_r,
                        c_az * k.cos_r + s_az * k.sin_r,
                    )
                };
                let xy = dist * k.cos_v;
                let xv = xy * sphi - k.horiz_off * cphi;
                let yv = xy * cphi + k.horiz_off * sphi;
                let z = dist * k.sin_v + k.vert_off;
                f(Point {
                    x: yv as f32,
                    y: -xv as f32,
                    z: z as f32,
                    time: (t_block + l as f64 * LASER_PERIOD_NS * 1e-9) as f32,
                    distance: dist as f32,
                    azimuth: (az as f64 * 0.01) as f32,
                    intensity: blk.intensity[l],
                    ring: k.ring,
                    laser: l as u8,
                    block: b as u8,
                    return_index: 0,
                });
            }
        }
    }

    /// Corrected distance of return `l` of block `b`, or `None` when it is
    /// no return (emitted as an empty point if asked) or closer than the
    /// minimum range.
    #[inline]
    fn distance(
        &self,
        blk: &super::packet::Block,
        b: usize,
        l: usize,
        f: &mut impl FnMut(Point),
    ) -> Option<f64> {
        let raw = blk.distance[l];
        if raw == 0 {
            if self.keep_empty {
                f(self.empty_point(blk.azimuth, blk.intensity[l], b, l));
            }
            return None;
        }
        let dist = raw as f64 * self.lsb + self.lasers[l].dist_corr;
        (dist >= self.min_distance_m).then_some(dist)
    }

    fn empty_point(&self, azimuth: u16, intensity: u8, b: usize, l: usize) -> Point {
        Point {
            time: ((b as f64 * BLOCK_PERIOD_NS + l as f64 * LASER_PERIOD_NS) * 1e-9) as f32,
            azimuth: (azimuth % 36000) as f32 * 0.01,
            intensity,
            ring: self.lasers[l].ring,
            laser: l as u8,
            block: b as u8,
            ..Point::default()
        }
    }

    /// Azimuth step from each block's firing to the next firing
    /// (hundredths of a degree); the last firing reuses the previous step.
    /// Steps above [`MAX_STEP_HUNDREDTHS`] are taken as 0.
    pub fn block_steps(p: &DataPacket) -> [u32; BLOCKS] {
        let k = p.blocks_per_firing();
        let mut d = [0u32; BLOCKS];
        for b in (0..BLOCKS).rev() {
            d[b] = if b + k < BLOCKS {
                azimuth_step(p.blocks[b].azimuth, p.blocks[b + k].azimuth)
            } else {
                0
            };
        }
        for b in BLOCKS - k..BLOCKS {
            d[b] = d[b - k];
        }
        d.map(|s| if s > MAX_STEP_HUNDREDTHS { 0 } else { s })
    }

    /// Call `f` for every non-zero return of the packet, block by block and
    /// laser by laser (firing order).
    #[inline]
    pub fn decode_with(&self, p: &DataPacket, mut f: impl FnMut(Point)) {
        let f = &mut f;
        if let Some(t) = &self.tables {
            return self.decode_veloview(p, t, f);
        }
        let pairs = self.mode == Interpolation::FixedPairs;
        let steps = Self::block_steps(p);
        let per_firing = p.blocks_per_firing();
        for (b, blk) in p.blocks.iter().enumerate() {
            // Sensors report 360.00 deg as 36000 at times.
            let az = (blk.azimuth % 36000) as f64;
            let (s0, c0) = (az * HUNDREDTH_RAD).sin_cos();
            let step = steps[b] as f64;
            // Both blocks of a dual-return pair come from one firing.
            let t_block = (b / per_firing) as f64 * BLOCK_PERIOD_NS * 1e-9;
            let return_index = (b % per_firing) as u8;
            for l in 0..LASERS {
                let Some(dist) = self.distance(blk, b, l, f) else {
                    continue;
                };
                let k = &self.lasers[l];
                // sin/cos of az + d by a short Taylor series in d.
                let d_hund = if pairs { (l / 2) as f64 } else { step * k.frac };
                let d = d_hund * HUNDREDTH_RAD;
                let d2 = d * d;
                let sd = d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0)));
                let cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0));
                let sa = s0 * cd + c0 * sd;
                let ca = c0 * cd - s0 * sd;
                // Angle of the laser: az - rot.
                let sphi = sa * k.cos_r - ca * k.sin_r;
                let cphi = ca * k.cos_r + sa * k.sin_r;
                let xy = dist * k.cos_v - k.vert_off * k.sin_v;
                // VeloView frame: x = xy sin(phi) - h cos(phi), y = xy cos(phi) + h sin(phi).
                let xv = xy * sphi - k.horiz_off * cphi;
                let yv = xy * cphi + k.horiz_off * sphi;
                let z = dist * k.sin_v + k.vert_off * k.cos_v;
                let mut azimuth = (az + d_hund) * 0.01;
                if azimuth >= 360.0 {
                    azimuth -= 360.0;
                }
                f(Point {
                    x: yv as f32,
                    y: -xv as f32,
                    z: z as f32,
                    time: (t_block + l as f64 * LASER_PERIOD_NS * 1e-9) as f32,
                    distance: dist as f32,
                    azimuth: azimuth as f32,
                    intensity: blk.intensity[l],
                    ring: k.ring,
                    laser: l as u8,
                    block: b as u8,
                    return_index,
                });
            }
        }
    }

    /// Append the packet's points to `out` without growing it past its
    /// capacity; returns the number of points that did not fit.
    pub fn decode_into(&self, p: &DataPacket, out: &mut Vec<Point>) -> usize {
        let mut lost = 0;
        self.decode_with(p, |pt| {
            if out.len() < out.capacity() {
                out.push(pt);
            } else {
                lost += 1;
            }
        });
        lost
    }
}
