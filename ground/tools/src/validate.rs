//! `speleo validate CASE`: replay one validation a mission dumped
//! (`--dump-validations`) with the configuration's simulator: its verdict
//! beside the mission's, where it tilted most, and on request the world
//! it built (PLY), its track step by step and the plan's poses (CSV). With `--world`, the
//! same plan is also driven on the world's true surface from where the
//! rover truly stood (the true track the simulation wrote beside the
//! cases): a verdict that differs there points at the map, not the
//! simulator.

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use speleo_physics::{quat, BodyState, Mesh};
use speleo_scheduler::histogram::Histogram;
use speleo_scheduler::realtime::thread_cpu_ns;
use speleo_simulator::{InternalSim, SimulatorParams, Stance, ValidationCase, Verdict};

use crate::Error;

/// What one drive to a verdict found.
pub struct Drive {
    pub verdict: Verdict,
    pub physics_steps: u64,
    pub triangles: usize,
    /// The most tilt, deg, and where the rover was then.
    pub max_tilt_deg: f64,
    pub max_tilt_at: [f64; 3],
    pub wall_ms: f64,
    /// The physics steps' CPU times, us: median, 99th percentile and
    /// the longest (what the worker's budget must hold), read as the
    /// report's task table reads its tasks' times.
    pub step_us: [f64; 3],
}

/// The case's verdict equals `v` (outcome, driving time and goal error
/// to the bit).
pub fn same_verdict(case: &ValidationCase, v: &Verdict) -> bool {
    case.verdict.is_some_and(|c| {
        c.outcome == v.outcome
            && c.drive_s.to_bits() == v.drive_s.to_bits()
            && c.goal_error_m.to_bits() == v.goal_error_m.to_bits()
    })
}

pub fn read_case(path: &Path) -> Result<ValidationCase, Error> {
    let f =
        std::fs::File::open(path).map_err(|e| format!("cannot open {}: {e}", path.display()))?;
    ValidationCase::read(&mut std::io::BufReader::new(f))
        .map_err(|e| format!("{}: {e}", path.display()).into())
}

/// Write `plan`'s poses as CSV: x, y, z (m) and yaw (deg), one a row.
pub fn write_plan(plan: &[[f64; 4]], w: &mut dyn Write) -> Result<(), Error> {
    writeln!(w, "x_m,y_m,z_m,yaw_deg")?;
    for [x, y, z, yaw] in plan {
        writeln!(w, "{x:.4},{y:.4},{z:.4},{:.2}", yaw.to_degrees())?;
    }
    Ok(())
}

/// Roll, pitch, yaw and tilt from upright of `s`, deg.
fn attitude(s: &BodyState) -> [f64; 4] {
    let (yaw, pitch, roll) = quat::to_ypr(&s.orientation);
    let [_, x, y, _] = s.orientation;
    let tilt = (1.0 - 2.0 * (x * x + y * y)).clamp(-1.0, 1.0).acos();
    [roll, pitch, yaw, tilt].map(f64::to_degrees)
}

/// Replay `case` with `params` on the clouds it holds.
pub fn replay(
    case: &ValidationCase,
    params: SimulatorParams,
    track: Option<&mut dyn Write>,
    mesh: Option<&mut dyn Write>,
) -> Result<Drive, Error> {
    let mut sim = InternalSim::new(params)?;
    sim.begin(case.start, case.plan.iter().copied());
    if case.way_back {
        sim.check_way_back();
    }
    drive(&mut sim, |s| s.step(case, 1), track, mesh)
}

/// Drive `plan` from `start` on `ground` as it is.
pub fn drive_on(
    ground: Mesh,
    start: Stance,
    way_back: bool,
    plan: &[[f64; 4]],
    params: SimulatorParams,
    track: Option<&mut dyn Write>,
) -> Result<Drive, Error> {
    let mut sim = InternalSim::new(params)?;
    sim.begin_on(start, plan.iter().copied(), ground);
    if way_back {
        sim.check_way_back();
    }
    drive(&mut sim, |s| s.step_without_clouds(1), track, None)
}

/// The validation begun in `sim` to its verdict, an item of work at a
/// time; each physics step's state as a CSV row into `track` if given,
/// and the world into `mesh` once the rover drives.
fn drive(
    sim: &mut InternalSim,
    mut step: impl FnMut(&mut InternalSim) -> Option<Verdict>,
    mut track: Option<&mut dyn Write>,
    mut mesh: Option<&mut dyn Write>,
) -> Result<Drive, Error> {
    let dt = sim.params().dt_s;
    if let Some(t) = track.as_deref_mut() {
        writeln!(
            t,
            "t_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg,tilt_deg,v_mps,w_radps,cpu_us,contact_tests,contact_points"
        )?;
    }
    let started = Instant::now();
    let (mut max_tilt_deg, mut max_tilt_at) = (0.0f64, [f64::NAN; 3]);
    let mut steps = 0u64;
    let mut step_times = Histogram::new();
    let verdict = loop {
        let driving = sim.work() == "drive";
        if driving && steps == 0 {
            if let (Some(m), Some(world)) = (mesh.as_deref_mut(), sim.world_mesh()) {
                world.write_ply(m)?;
            }
        }
        let c0 = thread_cpu_ns();
        let v = step(sim);
        if driving {
            let cpu_ns = thread_cpu_ns().saturating_sub(c0);
            step_times.record(cpu_ns);
            let cpu_us = cpu_ns as f64 * 1e-3;
            steps += 1;
            if let Some(s) = sim.rover_state() {
                let [roll, pitch, yaw, tilt] = attitude(s);
                if tilt > max_tilt_deg {
                    (max_tilt_deg, max_tilt_at) = (tilt, s.position);
                }
                if let Some(t) = track.as_deref_mut() {
                    let [x, y, z] = s.position;
                    let ts = steps as f64 * dt;
                    let (v, w) = sim.command();
                    let [_, tests, points] = sim.contact_load();
                    writeln!(
                        t,
                        "{ts:.2},{x:.4},{y:.4},{z:.4},{roll:.2},{pitch:.2},{yaw:.2},{tilt:.2},{v:.3},{w:.3},{cpu_us:.1},{tests},{points}"
                    )?;
                }
            }
        }
        if let Some(v) = v {
            break v;
        }
    };
    Ok(Drive {
        verdict,
        physics_steps: steps,
        triangles: sim.triangles(),
        max_tilt_deg,
        max_tilt_at,
        wall_ms: started.elapsed().as_secs_f64() * 1e3,
        step_us: step_figures(&step_times),
    })
}

/// Median, 99th percentile and largest of the recorded times, us (NaN
/// when none).
fn step_figures(h: &Histogram) -> [f64; 3] {
    if h.count() == 0 {
        return [f64::NAN; 3];
    }
    let us = |ns: u64| ns as f64 * 1e-3;
    [
        us(h.quantile_ns(0.5)),
        us(h.quantile_ns(0.99)),
        us(h.max_ns()),
    ]
}

/// A case in the world: the start (where and how the rover truly stood),
/// the plan, and SLAM's error when it began (see [`in_world`]).
pub type InWorld = (Stance, Vec<[f64; 4]>, [f64; 4]);

/// The case carried into the world by where the rover truly stood when
/// it began: its start and plan in the world frame, and SLAM's error then
/// (x, y, z m, yaw deg, map frame). `truth` is the CSV the mission wrote
/// beside the cases (`t_ns,x_m,y_m,z_m,qw,qx,qy,qz`), its first row the
/// first frame's pose: the map frame's origin.
pub fn in_world(case: &ValidationCase, truth: &str) -> Result<InWorld, Error> {
    // x, y, z, yaw of a row.
    let pose = |f: &[f64]| [f[1], f[2], f[3], quat::to_ypr(&[f[4], f[5], f[6], f[7]]).0];
    // The row's attitude (the world and the map frame differ by a yaw:
    // pitch and roll are the same in both).
    let tilt = |f: &[f64]| {
        let (_, pitch, roll) = quat::to_ypr(&[f[4], f[5], f[6], f[7]]);
        [pitch, roll]
    };
    // The first row is the first frame's: the map frame's origin.
    let mut origin: Option<[f64; 4]> = None;
    // The row nearest the case's time: how near, the pose.
    let mut best: Option<(u64, [f64; 4], [f64; 2])> = None;
    for (i, line) in truth.lines().enumerate().skip(1) {
        let f: Vec<f64> = line
            .split(',')
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|e| format!("the true track, line {}: {e}", i + 1))?;
        if f.len() != 8 {
            return Err(format!("the true track, line {}: 8 fields wanted", i + 1).into());
        }
        let p = pose(&f);
        origin.get_or_insert(p);
        let gap = (f[0] as u64).abs_diff(case.began_ns);
        if best.is_none_or(|(g, _, _)| gap < g) {
            best = Some((gap, p, tilt(&f)));
        }
    }
    let (Some(o), Some((gap, t, [pitch, roll]))) = (origin, best) else {
        return Err("the true track is empty".into());
    };
    if gap > 1_000_000_000 {
        return Err(format!(
            "the true track has nothing within a second of the case's time ({:.1} s)",
            case.began_ns as f64 * 1e-9
        )
        .into());
    }
    let [tx, ty, tz, true_yaw] = t;
    let [ex, ey, ez, eyaw] = case.start.xyz_yaw();
    let turn = true_yaw - eyaw;
    let (s, c) = turn.sin_cos();
    let to_world = |q: &[f64; 4]| {
        let (dx, dy) = (q[0] - ex, q[1] - ey);
        [
            tx + c * dx - s * dy,
            ty + s * dx + c * dy,
            q[2] - ez + tz,
            q[3] + turn,
        ]
    };
    let plan = case.plan.iter().map(to_world).collect();
    // The true pose in the map frame, against SLAM's.
    let (so, co) = o[3].sin_cos();
    let (dx, dy) = (tx - o[0], ty - o[1]);
    let in_map = [co * dx + so * dy, -so * dx + co * dy, tz - o[2]];
    let wrap = |a: f64| {
        (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
    };
    let error = [
        ex - in_map[0],
        ey - in_map[1],
        ez - in_map[2],
        wrap(eyaw - (true_yaw - o[3])).to_degrees(),
    ];
    let start = Stance {
        pitch,
        roll,
        ..Stance::level(tx, ty, tz, true_yaw)
    };
    Ok((start, plan, error))
}

/// The triangles of `mesh` near the plan: within `margin` of its box in
/// x and y, from a metre and a half under it to two metres over it.
pub fn crop(mesh: &Mesh, start: [f64; 3], plan: &[[f64; 4]], margin: f64) -> Mesh {
    let mut lo = start;
    let mut hi = lo;
    for q in plan {
        for k in 0..3 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
    }
    let (lo, hi) = (
        [lo[0] - margin, lo[1] - margin, lo[2] - 1.5],
        [hi[0] + margin, hi[1] + margin, hi[2] + 2.0],
    );
    // Vertices stay shared, as in the world: the physics treats the
    // surface as the mission's simulation does.
    let mut out = Mesh::default();
    let mut index = vec![u32::MAX; mesh.vertices.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        // The triangle's bounds meet the box (a flat world is two
        // triangles far larger than any box).
        let near = (0..3).all(|k| {
            let c = tri.map(|i| f64::from(mesh.vertices[i as usize][k]));
            c[0].min(c[1]).min(c[2]) <= hi[k] && c[0].max(c[1]).max(c[2]) >= lo[k]
        });
        if !near {
            continue;
        }
        let mut new = [0u32; 3];
        for (n, &i) in new.iter_mut().zip(tri) {
            let slot = &mut index[i as usize];
            if *slot == u32::MAX {
                *slot = out.vertices.len() as u32;
                out.vertices.push(mesh.vertices[i as usize]);
            }
            *n = *slot;
        }
        out.triangles.push(new);
        out.materials
            .push(mesh.materials.get(t).copied().unwrap_or_default());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_step_times_median_p99_and_largest() {
        let mut h = Histogram::new();
        for us in (1..=200u64).rev() {
            h.record(us * 1000);
        }
        // The histogram's buckets are within 6.25 % of their values; the
        // largest is exact.
        let [median, p99, max] = step_figures(&h);
        assert!((100.0..=100.0 * 1.0625).contains(&median), "{median}");
        assert!((198.0..=200.0).contains(&p99), "{p99}");
        assert_eq!(max, 200.0);
        assert!(step_figures(&Histogram::new()).iter().all(|x| x.is_nan()));
    }

    #[test]
    fn a_case_is_carried_into_the_world_by_the_true_pose_when_it_began() {
        let case = ValidationCase {
            began_ns: 2_000_000_000,
            start: Stance::level(1.0, 2.0, 0.1, 0.0),
            plan: vec![[1.0, 2.0, 0.0, 0.0], [3.0, 2.0, 0.2, 0.0]],
            ..ValidationCase::default()
        };
        // Truly at (11, 12, 0.6) heading 90 degrees at 2 s, pitched 0.1
        // rad nose down and rolled 0.05 rad.
        let [w, x, y, z] = quat::from_ypr(std::f64::consts::FRAC_PI_2, 0.1, 0.05);
        let truth = format!(
            "t_ns,x_m,y_m,z_m,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n2000000000,11,12,0.6,{w},{x},{y},{z}\n"
        );
        let (start, plan, err) = in_world(&case, &truth).expect("placed");
        assert!((start.yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        assert!((start.pitch - 0.1).abs() < 1e-9 && (start.roll - 0.05).abs() < 1e-9);
        let end = plan[1];
        // 2 m ahead along the map's x is 2 m along the world's y.
        for (got, want) in end
            .iter()
            .zip([11.0, 14.0, 0.7, std::f64::consts::FRAC_PI_2])
        {
            assert!((got - want).abs() < 1e-9, "{end:?}");
        }
        assert!(
            (err[0] + 10.0).abs() < 1e-9 && (err[3] + 90.0).abs() < 1e-9,
            "{err:?}"
        );
        // Nothing near the case's time, or a damaged line: refused.
        let far = ValidationCase {
            began_ns: 9_000_000_000,
            ..case.clone()
        };
        assert!(in_world(&far, &truth).is_err());
        assert!(in_world(&case, "t_ns,x\n1,2,3\n").is_err());
    }

    #[test]
    fn the_crop_keeps_the_triangles_near_the_plan_with_their_shared_vertices() {
        let m = Mesh {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [50.0, 50.0, 0.0],
                [-90.0, -90.0, 0.0],
                [90.0, -90.0, 0.0],
                [0.0, 90.0, 0.0],
            ],
            triangles: vec![[0, 1, 2], [1, 3, 2], [3, 3, 3], [4, 5, 6]],
            materials: vec![Default::default(); 4],
        };
        let c = crop(&m, [0.0; 3], &[[1.0, 1.0, 0.0, 0.0]], 1.0);
        assert_eq!(
            c.triangles.len(),
            3,
            "the far one left out, the large one kept"
        );
        assert_eq!(c.vertices.len(), 7, "shared vertices kept once");
    }
}
