//! Motion primitives for the rover: cubic Hermite splines from the start
//! cell's origin at a start heading to a lattice cell at an end heading,
//! forward and backward, kept only when the rover can follow them (the
//! curvature never exceeds that of its tightest turn). No point turns:
//! on rough lava they wear the wheels and shake the rover (as in the
//! reference paper, whose set had about 850 primitives).
//!
//! End cells come from rings of chord lengths: for a heading change `d`
//! bins the chord of a circular arc points `d / 2` bins off the start
//! heading; its end is rounded to the nearest cell, and the cells one to
//! either side of it give lane changes. Written as SBPL `.mprim`, so the
//! same file feeds SBPL, `speleo plan --sbpl-env` and the rover.

use std::fmt::Write as _;

use crate::mprim::{MotionPrimitive, MprimFile};

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct PrimitiveSpec {
    pub resolution_m: f64,
    pub angles: u32,
    /// Tightest turn the rover drives, m.
    pub min_turn_radius_m: f64,
    /// Chord lengths of forward primitives, in cells.
    pub forward_rings: Vec<u32>,
    /// Chord lengths of backward primitives, in cells (empty: none).
    pub backward_rings: Vec<u32>,
    /// Largest heading change, in bins.
    pub max_heading_change: u32,
    /// Lateral offsets tried around each arc's end, in cells (0: only the
    /// arc's own end).
    pub lateral_offsets: u32,
    pub backward_cost_mult: u32,
    /// Spacing of the intermediate poses, m.
    pub pose_spacing_m: f64,
}

impl Default for PrimitiveSpec {
    /// The simulated rover on the 0.1 m maps: 16 headings, turns no
    /// tighter than 0.5 m, forward chords of 0.3 to 2 m, backward of 0.5 m
    /// at three times the cost: 928 primitives, 58 for every heading.
    fn default() -> Self {
        PrimitiveSpec {
            resolution_m: 0.1,
            angles: 16,
            min_turn_radius_m: 0.5,
            forward_rings: vec![3, 6, 10, 15, 20],
            backward_rings: vec![5],
            max_heading_change: 2,
            lateral_offsets: 1,
            backward_cost_mult: 3,
            pose_spacing_m: 0.05,
        }
    }
}

/// A point and tangent of a cubic Hermite curve at `s` in [0, 1].
fn hermite(p1: [f64; 2], t0: [f64; 2], t1: [f64; 2], s: f64) -> ([f64; 2], [f64; 2], [f64; 2]) {
    let (s2, s3) = (s * s, s * s * s);
    let (h10, h01, h11) = (s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2);
    let (d10, d01, d11) = (
        3.0 * s2 - 4.0 * s + 1.0,
        -6.0 * s2 + 6.0 * s,
        3.0 * s2 - 2.0 * s,
    );
    let (e10, e01, e11) = (6.0 * s - 4.0, -12.0 * s + 6.0, 6.0 * s - 2.0);
    let f = |a: f64, b: f64, c: f64, k: usize| a * t0[k] + b * p1[k] + c * t1[k];
    (
        [f(h10, h01, h11, 0), f(h10, h01, h11, 1)],
        [f(d10, d01, d11, 0), f(d10, d01, d11, 1)],
        [f(e10, e01, e11, 0), f(e10, e01, e11, 1)],
    )
}

/// The poses of the spline from the origin at `th0` to `end` at `th1`
/// (`sign` -1 for backward: the rover faces `th` but moves against it),
/// or `None` when its curvature exceeds `max_curvature` or it would turn
/// against its direction of travel.
fn spline(
    end: [f64; 2],
    th0: f64,
    th1: f64,
    sign: f64,
    max_curvature: f64,
    spacing: f64,
) -> Option<Vec<[f64; 3]>> {
    let chord = end[0].hypot(end[1]);
    let t0 = [sign * chord * th0.cos(), sign * chord * th0.sin()];
    let t1 = [sign * chord * th1.cos(), sign * chord * th1.sin()];
    // Dense samples for the checks and the arc length.
    const N: usize = 200;
    let mut length = 0.0;
    let mut prev = [0.0, 0.0];
    let mut arc = Vec::with_capacity(N + 1);
    for i in 0..=N {
        let s = i as f64 / N as f64;
        let (p, d, dd) = hermite(end, t0, t1, s);
        let speed = d[0].hypot(d[1]);
        // The tangent must keep pointing along the direction of travel.
        let along = d[0] * t0[0] + d[1] * t0[1];
        if speed < 1e-9 || along <= 0.0 {
            return None;
        }
        let curvature = (d[0] * dd[1] - d[1] * dd[0]).abs() / speed.powi(3);
        if curvature > max_curvature {
            return None;
        }
        length += (p[0] - prev[0]).hypot(p[1] - prev[1]);
        prev = p;
        arc.push((length, p, d));
    }
    let n = ((length / spacing).ceil() as usize).max(1);
    let mut poses = Vec::with_capacity(n + 1);
    let mut k = 0;
    for j in 0..=n {
        let target = length * j as f64 / n as f64;
        while k + 1 < arc.len() && arc[k].0 < target {
            k += 1;
        }
        // Between the dense samples k - 1 and k, by arc length.
        let (l1, p1, d1) = arc[k];
        let (l0, p0, d0) = arc[k.saturating_sub(1)];
        let w = if l1 > l0 {
            (target - l0) / (l1 - l0)
        } else {
            1.0
        };
        let lerp = |a: [f64; 2], b: [f64; 2]| [a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1])];
        let (p, d) = (lerp(p0, p1), lerp(d0, d1));
        let heading = (sign * d[1]).atan2(sign * d[0]);
        poses.push([p[0], p[1], heading.rem_euclid(std::f64::consts::TAU)]);
    }
    // Exact ends, as SBPL expects.
    poses[0] = [0.0, 0.0, th0.rem_euclid(std::f64::consts::TAU)];
    poses[n] = [end[0], end[1], th1.rem_euclid(std::f64::consts::TAU)];
    Some(poses)
}

/// The primitives of `spec`, start heading by start heading.
pub fn generate(spec: &PrimitiveSpec) -> MprimFile {
    let n = spec.angles.max(1);
    let bin = std::f64::consts::TAU / n as f64;
    let res = spec.resolution_m;
    let max_curvature = 1.0 / spec.min_turn_radius_m;
    let mut primitives = Vec::new();
    for a in 0..n {
        let th0 = a as f64 * bin;
        let mut seen: Vec<[i32; 3]> = Vec::new();
        let directions = [
            (1.0, &spec.forward_rings, 1),
            (-1.0, &spec.backward_rings, spec.backward_cost_mult),
        ];
        for (sign, rings, mult) in directions {
            for &ring in rings.iter() {
                let m = spec.max_heading_change as i32;
                for d in -m..=m {
                    let th1 = th0 + d as f64 * bin;
                    let chord = th0 + d as f64 * bin / 2.0;
                    let (cx, cy) = (
                        sign * ring as f64 * chord.cos(),
                        sign * ring as f64 * chord.sin(),
                    );
                    let l = spec.lateral_offsets as i32;
                    for off in -l..=l {
                        // Sideways of the chord, rounded to a cell.
                        let (ox, oy) = (-chord.sin() * off as f64, chord.cos() * off as f64);
                        let end = [(cx + ox).round() as i32, (cy + oy).round() as i32];
                        let key = [end[0], end[1], (a as i32 + d).rem_euclid(n as i32)];
                        if end == [0, 0] || seen.contains(&key) {
                            continue;
                        }
                        let e = [end[0] as f64 * res, end[1] as f64 * res];
                        let Some(poses) =
                            spline(e, th0, th1, sign, max_curvature, spec.pose_spacing_m)
                        else {
                            continue;
                        };
                        seen.push(key);
                        primitives.push(MotionPrimitive {
                            id: 0,
                            start_angle: a,
                            end: key,
                            cost_mult: mult,
                            poses,
                        });
                    }
                }
            }
        }
    }
    // SBPL numbers primitives within each start heading.
    let mut count = vec![0; n as usize];
    for p in &mut primitives {
        p.id = count[p.start_angle as usize];
        count[p.start_angle as usize] += 1;
    }
    MprimFile {
        resolution_m: res,
        angles: n,
        primitives,
    }
}

/// The file as SBPL writes it.
pub fn to_mprim_text(f: &MprimFile) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "resolution_m: {:.6}", f.resolution_m);
    let _ = writeln!(s, "numberofangles: {}", f.angles);
    let _ = writeln!(s, "totalnumberofprimitives: {}", f.primitives.len());
    for p in &f.primitives {
        let _ = writeln!(s, "primID: {}", p.id);
        let _ = writeln!(s, "startangle_c: {}", p.start_angle);
        let _ = writeln!(s, "endpose_c: {} {} {}", p.end[0], p.end[1], p.end[2]);
        let _ = writeln!(s, "additionalactioncostmult: {}", p.cost_mult);
        let _ = writeln!(s, "intermediateposes: {}", p.poses.len());
        for q in &p.poses {
            let _ = writeln!(s, "{:.4} {:.4} {:.4}", q[0], q[1], q[2]);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_set_is_followable_forward_and_backward_and_reads_back() {
        let spec = PrimitiveSpec::default();
        let f = generate(&spec);
        let n = f.primitives.len();
        let counts: Vec<usize> = (0..16)
            .map(|a| f.primitives.iter().filter(|p| p.start_angle == a).count())
            .collect();
        assert!(counts.iter().all(|&c| c == counts[0]), "{counts:?}");
        assert_eq!(n, 928, "{counts:?}");
        // Every heading gets the same number (SBPL requires it).
        let per = n / 16;
        for a in 0..16 {
            let k = f.primitives.iter().filter(|p| p.start_angle == a).count();
            assert_eq!(k, per, "heading {a}");
        }
        for p in &f.primitives {
            let first = p.poses[0];
            let last = p.poses[p.poses.len() - 1];
            assert_eq!([first[0], first[1]], [0.0, 0.0]);
            assert!((last[0] - p.end[0] as f64 * 0.1).abs() < 1e-12);
            assert!((last[1] - p.end[1] as f64 * 0.1).abs() < 1e-12);
            // Consecutive poses are close and turn gently: no point turns.
            for w in p.poses.windows(2) {
                let step = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
                assert!(step > 0.0 && step <= 0.0501, "{step}");
                let dth = (w[1][2] - w[0][2] + std::f64::consts::PI)
                    .rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                assert!(dth.abs() <= step / 0.5 + 0.02, "turns {dth} over {step}");
            }
            // Backward ones move against the heading, at three times the cost.
            let th = first[2];
            let moved = last[0] * th.cos() + last[1] * th.sin();
            assert_eq!(moved < 0.0, p.cost_mult == 3, "{p:?}");
        }
        let text = to_mprim_text(&f);
        let back = crate::mprim::parse(&text).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back.primitives.len(), n);
        assert_eq!(text, to_mprim_text(&back), "the text is stable");
        assert_eq!(text, to_mprim_text(&generate(&spec)), "deterministic");
    }
}
