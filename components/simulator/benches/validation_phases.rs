//! The internal simulator's cost per unit of work, phase by phase, on the
//! short tube: HDL-32E-like scans cast from sensor poses along its route
//! (every metre over the first 14 m) are the map, and a 9 m plan along the
//! route is validated. Prints the wall time of a unit of each phase (the
//! last world taken down and the TSDF cleared, 256 points integrated, a
//! tile meshed and added to the world, a physics step), the simulated
//! seconds driven per wall second, and the wall time of whole validations.
//! These figures size the units in `run.rs`.
//!
//! `cargo bench -p speleo-simulator --bench validation_phases`

use std::time::Instant;

use speleo_simulator::{CloudSource, InternalSim, SimulatorParams, Stance};
use speleo_twin::lidar::LidarWorld;
use speleo_twin::world::World;

/// The HDL-32E's lasers: -30.67 to +10.67 deg; 0.4 deg between columns.
const LASERS: usize = 32;
const COLUMNS: usize = 900;
const SENSOR_HEIGHT_M: f64 = 0.6;

struct Scans {
    origins: Vec<[f64; 3]>,
    points: Vec<Vec<[f64; 3]>>,
}

impl CloudSource for Scans {
    fn keyframes(&self) -> usize {
        self.origins.len()
    }
    fn origin(&self, k: usize) -> Option<[f64; 3]> {
        self.origins.get(k).copied()
    }
    fn points(&self, k: usize, from: usize, n: usize, out: &mut Vec<[f64; 3]>) -> bool {
        out.clear();
        let p = &self.points[k];
        let to = (from + n).min(p.len());
        out.extend_from_slice(&p[from.min(to)..to]);
        to < p.len()
    }
}

fn scan(world: &LidarWorld, o: [f64; 3]) -> Vec<[f64; 3]> {
    let mut pts = Vec::with_capacity(LASERS * COLUMNS);
    for c in 0..COLUMNS {
        let az = c as f64 / COLUMNS as f64 * std::f64::consts::TAU;
        for l in 0..LASERS {
            let el = (-30.67 + l as f64 * 41.34 / 31.0).to_radians();
            let d = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
            if let Some((r, _, _)) = world.cast(o, d, 10.0) {
                pts.push([o[0] + r * d[0], o[1] + r * d[1], o[2] + r * d[2]]);
            }
        }
    }
    pts
}

/// The route point `s` metres from its start.
fn along(route: &[[f64; 3]], s: f64) -> [f64; 3] {
    let mut left = s;
    for w in route.windows(2) {
        let d = ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt();
        if left <= d && d > 0.0 {
            let t = left / d;
            return [0, 1, 2].map(|k| w[0][k] + t * (w[1][k] - w[0][k]));
        }
        left -= d;
    }
    route[route.len() - 1]
}

fn median(v: &mut [f64]) -> f64 {
    quantile(v, 0.5)
}

/// The `q` quantile (sorts `v`).
fn quantile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() as f64 * q) as usize).min(v.len() - 1)]
}

fn main() {
    let world = World::build("short-tube", 1).expect("short tube");
    let lidar = LidarWorld::new(&world.mesh).expect("ray caster");
    let route = &world.route;
    let mut scans = Scans {
        origins: Vec::new(),
        points: Vec::new(),
    };
    for k in 0..15 {
        let g = along(route, k as f64);
        let o = [g[0], g[1], g[2] + SENSOR_HEIGHT_M];
        scans.points.push(scan(&lidar, o));
        scans.origins.push(o);
    }
    let plan: Vec<[f64; 4]> = (0..=90)
        .map(|i| {
            let (a, b) = (
                along(route, 0.1 * i as f64),
                along(route, 0.1 * i as f64 + 0.1),
            );
            [a[0], a[1], a[2], (b[1] - a[1]).atan2(b[0] - a[0])]
        })
        .collect();
    let mut p = SimulatorParams::default();
    if let Some(dt) = std::env::var("DT").ok().and_then(|v| v.parse().ok()) {
        p.dt_s = dt;
    }
    if let Some(t) = std::env::var("TILE").ok().and_then(|v| v.parse().ok()) {
        p.tile_m = t;
    }
    let start = Stance::level(
        plan[0][0],
        plan[0][1],
        plan[0][2] + p.base_height_m,
        plan[0][3],
    );
    let mut sim = InternalSim::new(p.clone()).expect("simulator");
    let (mut clear, mut integrate, mut base) = (Vec::new(), Vec::new(), Vec::new());
    let (mut tiles, mut physics) = (Vec::new(), Vec::new());
    let mut whole = Vec::new();
    let mut verdict = None;
    for _ in 0..5 {
        sim.begin(start, plan.iter().copied());
        let began = Instant::now();
        loop {
            let work = sim.work();
            let t = Instant::now();
            let v = sim.step(&scans, 1);
            let us = t.elapsed().as_secs_f64() * 1e6;
            match work {
                "clear" => clear.push(us),
                "integrate" => integrate.push(us),
                "base" => base.push(us),
                "ground" => tiles.push(us),
                "drive" => physics.push(us),
                _ => {}
            }
            if v.is_some() {
                verdict = v;
                break;
            }
        }
        whole.push(began.elapsed().as_secs_f64());
    }
    let v = verdict.expect("a verdict");
    let steps = physics.len() / 5;
    let phys_med = median(&mut physics);
    println!(
        "short tube, 9 m plan, {} keyframes of ~{} points: {:?} in {:.1} s driven, {} triangles",
        scans.origins.len(),
        scans.points[0].len(),
        v.outcome,
        v.drive_s,
        sim.triangles()
    );
    println!(
        "clear:     {} units a run (the last world taken down, the TSDF cleared), median {:.1} us, max {:.0} us",
        clear.len() / 5,
        median(&mut clear),
        clear[clear.len() - 1]
    );
    println!(
        "integrate: {} units a run, median {:.1} us, p99.9 {:.0} us",
        integrate.len() / 5,
        median(&mut integrate),
        quantile(&mut integrate, 0.999)
    );
    println!(
        "base:      the rover put down with its pad and strip, median {:.0} us, max {:.0} us",
        median(&mut base),
        base[base.len() - 1]
    );
    // The first tile of the first run also builds the collider pipeline's
    // storage: its max is start-up, the p99.9 is what a unit must hold.
    let tile_med = median(&mut tiles);
    println!(
        "tiles:     {} a run, median {tile_med:.0} us, p90 {:.0} us, p99.9 {:.0} us, max {:.0} us",
        tiles.len() / 5,
        quantile(&mut tiles, 0.9),
        quantile(&mut tiles, 0.999),
        tiles[tiles.len() - 1]
    );
    println!(
        "physics:   {steps} steps a run, median {phys_med:.1} us a {} ms step ({:.1}x real time), p99.9 {:.0} us",
        p.dt_s * 1e3,
        p.dt_s * 1e6 / phys_med,
        quantile(&mut physics, 0.999)
    );
    println!("whole validation: median {:.2} s wall", median(&mut whole));
}
