//! The true world's ground as a multi-level surface map: what a perfect
//! sensor would have mapped, for the coverage figures of a simulated
//! mission and for planning on a world (`speleo plan --world`).

use speleo_mapping::mls::{MlsMap, MlsParams};
use speleo_twin::lidar::LidarWorld;
use speleo_twin::world::World;

type Error = Box<dyn std::error::Error>;

/// Spacing of the points sampled on the mesh, m.
const SAMPLE_M: f64 = 0.05;

/// The mesh's surface as a multi-level surface map: every point of a face
/// that a sensor could see, sampled on a barycentric grid of `SAMPLE_M`.
/// A point is hidden when the ray along its face's normal, from just in
/// front of it, meets the back of a face first: it lies inside a solid
/// (the buried foot of a ramp, the part of a slab's underside inside
/// another slab). Levels split
/// at 0.2 m rather than the sensor maps' 0.3 m, so that a 0.25 m slab
/// stays a floor over its own underside instead of becoming a wall.
pub fn surface_map(w: &World) -> Result<MlsMap, Error> {
    let mut mls = MlsMap::new(MlsParams {
        max_cells: 1 << 20,
        max_patches_per_cell: 8,
        gap_m: 0.2,
        vertical_threshold_m: 0.15,
        ..MlsParams::default()
    })?;
    let m = &w.mesh;
    let rays = LidarWorld::new(m)?;
    let mut pts = Vec::with_capacity(1 << 16);
    for (k, t) in m.triangles.iter().enumerate() {
        let [a, b, c] = t.map(|i| m.vertices[i as usize].map(f64::from));
        let (_, n) = m.triangle_geometry(k);
        let hidden = |p: [f64; 3]| {
            let front = [0, 1, 2].map(|i| p[i] + 0.02 * n[i]);
            rays.cast_signed(front, n, 1000.0)
                .is_some_and(|(_, facing)| facing > 0.0)
        };
        let len = |p: [f64; 3], q: [f64; 3]| {
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
        };
        let longest = len(a, b).max(len(b, c)).max(len(c, a));
        let steps = ((longest / SAMPLE_M).ceil() as usize).clamp(1, 4096);
        for i in 0..=steps {
            for j in 0..=steps - i {
                let (u, v) = (i as f64 / steps as f64, j as f64 / steps as f64);
                let p = [0, 1, 2].map(|k| a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]));
                if !hidden(p) {
                    pts.push(p);
                }
            }
        }
        if pts.len() > 1 << 16 {
            mls.insert_points(&pts);
            pts.clear();
        }
    }
    mls.insert_points(&pts);
    Ok(mls)
}
