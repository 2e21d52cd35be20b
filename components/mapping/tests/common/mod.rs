//! Synthetic scenes shared by the tests and the benchmarks: a small
//! deterministic generator, an HDL-32E-like scan pattern cast in a lava
//! tube (a cylinder with a flat floor, closed at both ends), and a sphere
//! seen from outside.

#![allow(dead_code)]

use speleo_mapping::marching_cubes::Mesh;
use std::collections::HashMap;

/// SplitMix64: uniform numbers in [0, 1) and Gaussian ones, the same on
/// every run.
pub struct Rng(pub u64);

impl Rng {
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn gauss(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        let v = self.uniform();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// The lava tube: axis along x, wall radius `radius` around the axis
/// (y = z = 0), a flat floor at `floor_z`, end walls at `x_min`, `x_max`.
#[derive(Clone, Copy, Debug)]
pub struct Tube {
    pub radius: f64,
    pub floor_z: f64,
    pub x_min: f64,
    pub x_max: f64,
}

pub const TUBE: Tube = Tube {
    radius: 2.0,
    floor_z: -1.2,
    x_min: -10.0,
    x_max: 40.0,
};

impl Tube {
    /// Distance along unit direction `d` from `o` (inside the tube) to the
    /// first surface.
    pub fn cast(&self, o: [f64; 3], d: [f64; 3]) -> f64 {
        let mut t = f64::INFINITY;
        // Wall: (oy + t dy)^2 + (oz + t dz)^2 = r^2, the root ahead.
        let a = d[1] * d[1] + d[2] * d[2];
        if a > 1e-12 {
            let b = o[1] * d[1] + o[2] * d[2];
            let c = o[1] * o[1] + o[2] * o[2] - self.radius * self.radius;
            let disc = b * b - a * c;
            if disc >= 0.0 {
                t = t.min((-b + disc.sqrt()) / a);
            }
        }
        if d[2] < 0.0 {
            t = t.min((self.floor_z - o[2]) / d[2]);
        }
        if d[0] > 0.0 {
            t = t.min((self.x_max - o[0]) / d[0]);
        } else if d[0] < 0.0 {
            t = t.min((self.x_min - o[0]) / d[0]);
        }
        t
    }
}

/// Unit directions of one HDL-32E revolution: 32 lasers from -30.67 to
/// +10.67 degrees elevation, 1800 azimuths (0.2 degree): 57,600 rays.
pub fn hdl32e_directions() -> Vec<[f64; 3]> {
    let mut out = Vec::with_capacity(57_600);
    for a in 0..1800 {
        let az = (a as f64 * 0.2).to_radians();
        for l in 0..32 {
            let el = (-30.67 + l as f64 * (41.34 / 31.0)).to_radians();
            out.push([el.cos() * az.cos(), el.cos() * az.sin(), el.sin()]);
        }
    }
    out
}

/// One revolution from a sensor at `origin` (level, facing +x) in the
/// tube, in the sensor frame, with Gaussian range noise of `sigma` m.
pub fn tube_scan(origin: [f64; 3], sigma: f64, rng: &mut Rng) -> Vec<[f32; 3]> {
    hdl32e_directions()
        .iter()
        .map(|d| {
            let r = TUBE.cast(origin, *d) + sigma * rng.gauss();
            [(d[0] * r) as f32, (d[1] * r) as f32, (d[2] * r) as f32]
        })
        .collect()
}

/// Sensor origins of `n` scans 1 m apart along the tube axis, 0.6 m above
/// the floor.
pub fn tube_origins(n: usize) -> Vec<[f64; 3]> {
    (0..n)
        .map(|k| [k as f64, 0.0, TUBE.floor_z + 0.6])
        .collect()
}

/// `n` scans in the tube, each as (origin, points in the map frame).
pub fn tube_scans_map(n: usize, sigma: f64) -> Vec<([f64; 3], Vec<[f64; 3]>)> {
    let mut rng = Rng(42);
    tube_origins(n)
        .into_iter()
        .map(|o| {
            let pts = tube_scan(o, sigma, &mut rng)
                .iter()
                .map(|p| [o[0] + p[0] as f64, o[1] + p[1] as f64, o[2] + p[2] as f64])
                .collect();
            (o, pts)
        })
        .collect()
}

pub const SPHERE_CENTER: [f64; 3] = [0.31, -0.17, 0.12];
pub const SPHERE_RADIUS: f64 = 1.0;

/// Sensor origins around the sphere: the six axes and eight diagonals,
/// 3 m from its centre.
pub fn sphere_origins() -> Vec<[f64; 3]> {
    let mut dirs: Vec<[f64; 3]> = Vec::new();
    for a in 0..3 {
        for s in [-1.0, 1.0] {
            let mut d = [0.0; 3];
            d[a] = s;
            dirs.push(d);
        }
    }
    let k = 1.0 / 3f64.sqrt();
    for i in 0..8 {
        let s = |b: usize| if (i >> b) & 1 == 1 { k } else { -k };
        dirs.push([s(0), s(1), s(2)]);
    }
    dirs.iter()
        .map(|d| std::array::from_fn(|a| SPHERE_CENTER[a] + 3.0 * d[a]))
        .collect()
}

/// Points of the sphere seen from `origin`: `n` points spread evenly over
/// the sphere (a Fibonacci lattice), kept where the view is within
/// `max_incidence_deg` of the surface normal (grazing returns are left
/// out, as a real sensor's would be unreliable).
pub fn sphere_view(origin: [f64; 3], n: usize, max_incidence_deg: f64) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let cos_max = max_incidence_deg.to_radians().cos();
    let mut out = Vec::new();
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let th = golden * i as f64;
        let nrm = [r * th.cos(), r * th.sin(), z];
        let p: [f64; 3] = std::array::from_fn(|a| SPHERE_CENTER[a] + SPHERE_RADIUS * nrm[a]);
        let v: [f64; 3] = std::array::from_fn(|a| origin[a] - p[a]);
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let cos = (v[0] * nrm[0] + v[1] * nrm[1] + v[2] * nrm[2]) / len;
        if cos >= cos_max {
            out.push(p);
        }
    }
    out
}

/// Per undirected edge, how many triangles use it; and whether each
/// directed edge is used at most once (consistent orientation).
pub fn edge_use(mesh: &Mesh) -> (HashMap<(u32, u32), u32>, bool) {
    let mut undirected = HashMap::new();
    let mut directed = HashMap::new();
    let mut consistent = true;
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *undirected.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            let d = directed.entry((a, b)).or_insert(0);
            *d += 1;
            consistent &= *d == 1;
        }
    }
    (undirected, consistent)
}
