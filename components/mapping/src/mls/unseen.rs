//! Ground a scan should have seen and did not: where the downward rings of
//! a spinning LiDAR meet the plane the rover stands on, near the rover.
//!
//! A ring's return from that plane lands at one distance, whatever the
//! ground beyond does: ground at the plane's height or over it stops the
//! ray there, ground under it lets the ray go on. So when the cell where a
//! ray would meet the plane holds nothing after the scan, nothing stands
//! there at the plane's height or over it ([`MlsMap::mark_unseen_ground`]).
//! That is the only sign of an open edge with nothing seen under it (a
//! roof's rim, a cliff over a void): no ray comes back from beyond it.
//!
//! A ray that met something first (a wall, a rock, ground lower than the
//! plane) proves nothing past it: along each azimuth the rings are taken
//! nearest first, and marks follow only an unbroken run of ground at the
//! plane's height (or of marks) from the rover out, on cells whose next
//! ring out finds nothing either. The ground between
//! the rover's body and the nearest ring is in no ring's sight: it counts
//! as the rover's own unless something there stands over the plane.

use nalgebra::{Isometry3, Point3, Vector3};

use super::MlsMap;

/// Ground this near the plane's height continues the rover's plane, m:
/// lava floors rock by a few centimetres under a rover-sized plane.
const ON_PLANE_M: f32 = 0.08;
/// The rover's body reaches this far from the sensor's foot, m; between
/// it and the nearest ring, anything this much over the plane may have
/// shadowed the rings.
const BODY_REACH_M: f64 = 0.45;
const SHADOW_OVER_M: f32 = 0.05;

/// Where the downward rings meet the ground plane of the base frame,
/// worked out once at start-up.
#[derive(Clone, Debug)]
pub struct ExpectedGround {
    /// Per azimuth, `rings` hits in the base frame, nearest first; unused
    /// slots (rings that do not reach the plane within range) are NaN.
    hits: Vec<[f64; 3]>,
    rings: usize,
    /// Per azimuth, points of the plane every cell's width from the
    /// body's reach to the nearest ring (NaN-padded, `near` a row).
    near_ground: Vec<[f64; 3]>,
    near: usize,
}

impl ExpectedGround {
    /// For a LiDAR at `mount` (base <- sensor) whose lasers point
    /// `elevations_deg` over its horizontal plane, on ground at height
    /// `ground_z` in the base frame; rings meeting it farther than
    /// `reach_m` from the sensor's foot are left out (grazing rays land
    /// centimetres of height away from where a plane puts them), and
    /// `azimuths` directions around. Allocates here only.
    pub fn new(
        mount: &Isometry3<f64>,
        elevations_deg: &[f64],
        ground_z: f64,
        reach_m: f64,
        azimuths: usize,
    ) -> Self {
        let rings = elevations_deg.len();
        let mut hits = vec![[f64::NAN; 3]; rings * azimuths];
        let step = 0.1;
        let near = ((reach_m - BODY_REACH_M) / step).ceil().max(1.0) as usize;
        let mut near_ground = vec![[f64::NAN; 3]; near * azimuths];
        let origin = mount.translation.vector;
        let mut row: Vec<(f64, [f64; 3])> = Vec::with_capacity(rings);
        for a in 0..azimuths {
            let az = a as f64 * std::f64::consts::TAU / azimuths as f64;
            row.clear();
            for e in elevations_deg.iter().map(|e| e.to_radians()) {
                let u =
                    mount.rotation * Vector3::new(e.cos() * az.cos(), e.cos() * az.sin(), e.sin());
                if u.z >= -1e-6 {
                    continue;
                }
                let p = origin + u * ((ground_z - origin.z) / u.z);
                let d = (p.x - origin.x).hypot(p.y - origin.y);
                if d.is_finite() && d <= reach_m {
                    row.push((d, [p.x, p.y, p.z]));
                }
            }
            row.sort_by(|x, y| x.0.total_cmp(&y.0));
            for (k, (_, p)) in row.iter().enumerate() {
                hits[a * rings + k] = *p;
            }
            let first = row.first().map_or(0.0, |r| r.0);
            let (dx, dy) = (az.cos(), az.sin());
            for k in 0..near {
                let r = BODY_REACH_M + k as f64 * step;
                if r >= first {
                    break;
                }
                near_ground[a * near + k] = [origin.x + r * dx, origin.y + r * dy, ground_z];
            }
        }
        ExpectedGround {
            hits,
            rings,
            near_ground,
            near,
        }
    }

    /// How far the seen ground lies over the plane round the rover: the
    /// mean over the azimuths whose nearest ring met ground near the
    /// plane. Marks are made at the ground's height, not the plane's: the
    /// base's height over the ground is a model's, and SLAM's height
    /// drifts by centimetres from keyframe to keyframe.
    pub fn lift(&self, map: &MlsMap, base_to_map: &Isometry3<f64>) -> f64 {
        let (mut sum, mut n) = (0.0f64, 0u32);
        for row in self.hits.chunks(self.rings.max(1)) {
            let Some(h) = row.first().filter(|h| !h[0].is_nan()) else {
                continue;
            };
            let p = base_to_map * Point3::from(*h);
            let (ix, iy) = map.cell_of(p.x, p.y);
            let z = p.z as f32;
            let nearest = map
                .cell(ix, iy)
                .iter()
                .filter_map(|q| q.ground())
                .filter(|g| (g - z).abs() <= ON_PLANE_M)
                .min_by(|a, b| (a - z).abs().total_cmp(&(b - z).abs()));
            if let Some(g) = nearest {
                sum += (g - z) as f64;
                n += 1;
            }
        }
        if n == 0 {
            0.0
        } else {
            sum / n as f64
        }
    }

    /// Directions around the sensor.
    pub fn azimuths(&self) -> usize {
        self.hits.len() / self.rings.max(1)
    }

    /// Marks in `map` the cells where a scan taken at `base_to_map` (its
    /// points already in the map) should have met the ground plane and
    /// met nothing, among those `keep(x, y)` accepts; returns how many.
    /// [`ExpectedGround::lift`] and [`ExpectedGround::mark_azimuths`] over
    /// every azimuth. Allocates nothing.
    pub fn mark(
        &self,
        map: &mut MlsMap,
        base_to_map: &Isometry3<f64>,
        keep: impl Fn(f64, f64) -> bool,
    ) -> usize {
        let lift = self.lift(map, base_to_map);
        self.mark_azimuths(map, base_to_map, lift, 0..self.azimuths(), keep)
    }

    /// [`ExpectedGround::mark`] along the azimuths `range` only, with the
    /// ground `lift` over the plane already worked out: the work cut into
    /// bounded steps (a whole scan's marks took milliseconds).
    pub fn mark_azimuths(
        &self,
        map: &mut MlsMap,
        base_to_map: &Isometry3<f64>,
        lift: f64,
        range: std::ops::Range<usize>,
        keep: impl Fn(f64, f64) -> bool,
    ) -> usize {
        let mut marks = 0;
        let (rings, near) = (self.rings.max(1), self.near.max(1));
        let range = range.start.min(self.azimuths())..range.end.min(self.azimuths());
        let rows = self.hits[range.start * rings..range.end * rings].chunks(rings);
        let nears = self.near_ground[range.start * near..range.end * near].chunks(near);
        for (row, near) in rows.zip(nears) {
            let mut on_ground = !near.iter().take_while(|h| !h[0].is_nan()).any(|h| {
                let p = base_to_map * Point3::from(*h);
                let (ix, iy) = map.cell_of(p.x, p.y);
                let over = p.z as f32 + SHADOW_OVER_M;
                map.cell(ix, iy).iter().any(|q| q.max > over)
            });
            let row = &row[..row.iter().take_while(|h| !h[0].is_nan()).count()];
            for (k, h) in row.iter().enumerate() {
                let p = base_to_map * Point3::from(*h);
                let (ix, iy) = map.cell_of(p.x, p.y);
                let z = p.z as f32;
                let cell = map.cell(ix, iy);
                if cell.is_empty() {
                    // The next ring's cell empty too: ground falling away
                    // past a crest stretches the rings apart and leaves a
                    // cell between two of them empty, which is no edge.
                    let next_empty = || {
                        row[k + 1..]
                            .iter()
                            .map(|n| {
                                let q = base_to_map * Point3::from(*n);
                                map.cell_of(q.x, q.y)
                            })
                            .find(|&c| c != (ix, iy))
                            .is_some_and(|(jx, jy)| map.cell(jx, jy).is_empty())
                    };
                    if on_ground
                        && keep(p.x, p.y)
                        && next_empty()
                        && map.mark_unseen_ground(p.x, p.y, p.z + lift)
                    {
                        marks += 1;
                    }
                    continue;
                }
                let level = cell
                    .iter()
                    .any(|q| q.ground().is_some_and(|g| (g - z).abs() <= ON_PLANE_M));
                if !level {
                    // A wall, a rock or lower ground took this ray: the
                    // ones beyond prove nothing.
                    break;
                }
                on_ground = true;
            }
        }
        marks
    }
}
