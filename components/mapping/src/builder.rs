//! Building the multi-level surface maps from the keyframes, in bounded
//! units of work. Each unit inserts at most `points_per_step` points: the
//! next part of a new keyframe's cloud at its optimised pose, or of a
//! re-projection. When the pose graph has moved a keyframe already in the
//! map by more than `reproject_m` or `reproject_deg` (a loop closure),
//! every keyframe is inserted again at its new pose into the spare map
//! while the serving one keeps serving; the two swap when it is complete.
//!
//! The maps are bounded: once the serving map holds all but a step's cells,
//! it is rebuilt the same way from the points within `keep_radius_m` of the
//! newest keyframe (in the plane), and from then on every rebuild keeps to
//! the region around the rover. A rebuild is cut into the same units as
//! any insertion, so keeping the region costs no longer step than mapping.

use speleo_slam::lie::{log_so3, Pose};

use crate::keyframes::KeyframeClouds;
use crate::mls::ExpectedGround;
use crate::surface_maps::SurfaceMaps;

/// The builder's settings (`[maps]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuilderParams {
    /// Points one unit of work inserts at most.
    pub points_per_step: usize,
    /// A keyframe moved this far or turned this much since it went in
    /// starts a re-projection, m and deg.
    pub reproject_m: f64,
    pub reproject_deg: f64,
    /// A full map is rebuilt from the points this near the rover, m.
    pub keep_radius_m: f64,
    /// The LiDAR's range, m.
    pub range_m: f64,
}

/// How far the LiDAR may sit from the base, m (clouds are in the base
/// frame, their range counted from the sensor).
const MOUNT_REACH_M: f64 = 2.0;

/// What the builder has done.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MapsCounters {
    /// Keyframes inserted as they came.
    pub keyframes_inserted: u64,
    /// Re-projections of every keyframe started because the pose graph
    /// moved one, and rebuilds of either kind completed.
    pub reprojections_started: u64,
    pub reprojections: u64,
    /// Rebuilds that kept only the region around the rover, started
    /// because the serving map filled up.
    pub regions_kept: u64,
    pub points_inserted: u64,
    /// Points of a rebuild left out for lying beyond the kept region.
    pub points_outside_region: u64,
    /// Cells marked where a keyframe's rings should have met ground and
    /// met nothing (see `ExpectedGround`).
    pub unseen_ground_marks: u64,
}

/// Azimuths of the unseen-ground marks one step makes: a keyframe's 360
/// took ~2 ms, over the task's budget, in one step.
const MARK_AZIMUTHS_PER_STEP: usize = 40;

/// Where the insertion is: keyframe `k`, from its point `point`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Cursor {
    k: usize,
    point: usize,
}

pub struct MapBuilder {
    /// Keyframes in the serving map and the pose each went in at.
    inserted: Vec<Pose>,
    /// A keyframe part-way into the serving map.
    adding: Option<Cursor>,
    /// The re-projection into the other map, when one runs.
    rebuilding: Option<Cursor>,
    /// Poses the rebuild inserted at (the serving map's once it swaps).
    rebuilt: Vec<Pose>,
    /// The rebuild keeps only points within `keep_radius_m` of this
    /// point (map frame, x and y).
    region: Option<[f64; 2]>,
    /// Once a map has filled up, every rebuild keeps to a region.
    bounded: bool,
    /// The serving map is kept to a region when it holds this many cells.
    keep_cells: usize,
    keep_radius_m: f64,
    /// How far a keyframe's points lie from its pose at most.
    cloud_reach_m: f64,
    /// Keyframes inserted since the last rebuild (a rebuild that could
    /// not make room is not started again before the map changes).
    since_rebuild: u64,
    generation_seen: u64,
    reproject_m: f64,
    reproject_rad: f64,
    /// The LiDAR's position in the base frame: what a point was seen
    /// from (over it or under it) matters to the MLS.
    sensor_in_base: nalgebra::Vector3<f64>,
    /// Where each keyframe's downward rings meet the rover's ground, to
    /// mark what they should have seen and did not.
    expected_ground: Option<ExpectedGround>,
    /// The ground's lift over the plane of the keyframe being marked.
    mark_lift: f64,
    /// Scratch: one step's points in the map frame.
    scratch: Vec<[f64; 3]>,
    points_per_step: usize,
    pub counters: MapsCounters,
}

impl MapBuilder {
    /// The builder for `keyframes` keyframes into maps of `max_cells`
    /// cells (`SurfaceMaps::new`'s).
    pub fn new(p: &BuilderParams, max_cells: usize, keyframes: usize) -> Self {
        let points_per_step = p.points_per_step.max(1);
        let (reproject_m, reproject_deg) = (p.reproject_m, p.reproject_deg);
        let keep_radius_m = p.keep_radius_m;
        MapBuilder {
            cloud_reach_m: p.range_m + MOUNT_REACH_M,
            // Room for one more step of points in new cells.
            keep_cells: max_cells.saturating_sub(points_per_step),
            keep_radius_m,
            region: None,
            bounded: false,
            since_rebuild: 0,
            inserted: Vec::with_capacity(keyframes),
            adding: None,
            rebuilding: None,
            rebuilt: Vec::with_capacity(keyframes),
            generation_seen: 0,
            reproject_m,
            reproject_rad: reproject_deg.to_radians(),
            sensor_in_base: nalgebra::Vector3::zeros(),
            expected_ground: None,
            mark_lift: 0.0,
            scratch: Vec::with_capacity(points_per_step),
            points_per_step,
            counters: MapsCounters::default(),
        }
    }

    /// The LiDAR sits at `xyz` in the base frame (`lidar.mount_xyz`).
    pub fn with_sensor_at(mut self, xyz: [f64; 3]) -> Self {
        self.sensor_in_base = nalgebra::Vector3::from(xyz);
        self
    }

    /// Mark, after each keyframe, the cells where its rings should have
    /// met the ground the rover stood on and met nothing.
    pub fn with_expected_ground(mut self, g: ExpectedGround) -> Self {
        self.expected_ground = Some(g);
        self
    }

    /// Whether some keyframe in the serving map has moved beyond the
    /// thresholds since it was inserted.
    fn moved(&self, clouds: &KeyframeClouds) -> bool {
        self.inserted.iter().enumerate().any(|(k, at)| {
            clouds.pose(k).is_some_and(|now| {
                let d = at.between(now);
                d.t.norm() > self.reproject_m || log_so3(&d.r).norm() > self.reproject_rad
            })
        })
    }

    /// Insert the next part of keyframe `c.k` into map `m`; returns the
    /// cursor to go on from, or `None` when the keyframe is done.
    fn insert_part(
        &mut self,
        clouds: &KeyframeClouds,
        maps: &mut SurfaceMaps,
        m: usize,
        c: Cursor,
    ) -> Option<Cursor> {
        let store = clouds;
        let pose = *store.pose(c.k)?;
        let n = store.cloud(c.k).len();
        if c.point >= n && self.expected_ground.is_some() {
            return self.mark_part(clouds, maps, m, c, n);
        }
        self.scratch.clear();
        let cloud = clouds.cloud(c.k);
        let keeps = self.keeps(maps, m);
        let mut taken = 0;
        for p in cloud.skip(c.point).take(self.points_per_step) {
            taken += 1;
            let v = pose.transform(&nalgebra::Vector3::from(p));
            if !keeps(v.x, v.y) {
                self.counters.points_outside_region += 1;
                continue;
            }
            self.scratch.push([v.x, v.y, v.z]);
        }
        let sensor_z = pose.transform(&self.sensor_in_base).z;
        let stats = maps
            .map_mut(m)
            .insert_points_seen_from(&self.scratch, sensor_z);
        self.counters.points_inserted += stats.inserted;
        let next = c.point + taken;
        // With marks to make, the keyframe goes on past its points.
        (next < n || self.expected_ground.is_some()).then_some(Cursor {
            k: c.k,
            point: next,
        })
    }

    /// The marks of keyframe `c.k` (its points all in map `m`) where its
    /// rings should have met the ground and met nothing, in steps: past
    /// the cloud's `n` points, `c.point` counts them (the ground's lift
    /// over the plane first, then [`MARK_AZIMUTHS_PER_STEP`] azimuths a
    /// step).
    fn mark_part(
        &mut self,
        clouds: &KeyframeClouds,
        maps: &mut SurfaceMaps,
        m: usize,
        c: Cursor,
        n: usize,
    ) -> Option<Cursor> {
        let pose = clouds.pose(c.k)?.to_isometry();
        let g = self.expected_ground.as_ref()?;
        let map = maps.map_mut(m);
        let at = c.point - n;
        if at == 0 {
            self.mark_lift = g.lift(map, &pose);
            return Some(Cursor {
                k: c.k,
                point: c.point + 1,
            });
        }
        let keep = self.keeps(maps, m);
        let from = (at - 1) * MARK_AZIMUTHS_PER_STEP;
        let to = (from + MARK_AZIMUTHS_PER_STEP).min(g.azimuths());
        let map = maps.map_mut(m);
        let marks = g.mark_azimuths(map, &pose, self.mark_lift, from..to, keep);
        self.counters.unseen_ground_marks += marks as u64;
        (to < g.azimuths()).then_some(Cursor {
            k: c.k,
            point: c.point + 1,
        })
    }

    /// Whether a point at `x, y` goes into map `m`: the active map takes
    /// everything, a map being rebuilt only what lies in the kept region.
    fn keeps(&self, maps: &SurfaceMaps, m: usize) -> impl Fn(f64, f64) -> bool {
        let region = if m == maps.active() {
            None
        } else {
            self.region
        };
        let r2 = self.keep_radius_m * self.keep_radius_m;
        move |x: f64, y: f64| {
            region.is_none_or(|[cx, cy]| (x - cx).powi(2) + (y - cy).powi(2) <= r2)
        }
    }

    /// One bounded unit of work (at most `points_per_step` points) from
    /// the keyframe `clouds` into `maps`; false when there is none.
    pub fn work(&mut self, clouds: &KeyframeClouds, maps: &mut SurfaceMaps) -> bool {
        // A re-projection under way: the next part into the other map.
        if let Some(c) = self.rebuilding {
            let spare = 1 - maps.active();
            let Some(pose) = clouds.pose(c.k) else {
                return false;
            };
            if c.point == 0 {
                push_bounded(&mut self.rebuilt, *pose);
            }
            // A keyframe too far from the kept region to reach it is passed.
            let far = self.region.is_some_and(|[x, y]| {
                (pose.t.x - x).hypot(pose.t.y - y) > self.keep_radius_m + self.cloud_reach_m
            });
            let next = if far {
                None
            } else {
                self.insert_part(clouds, maps, spare, c)
            };
            self.rebuilding = match next {
                Some(next) => Some(next),
                None if c.k + 1 < clouds.ready() => Some(Cursor {
                    k: c.k + 1,
                    point: 0,
                }),
                None => {
                    // Complete: the rebuilt map serves.
                    maps.swap();
                    std::mem::swap(&mut self.inserted, &mut self.rebuilt);
                    self.rebuilt.clear();
                    self.adding = None;
                    self.since_rebuild = 0;
                    self.region = None;
                    self.counters.reprojections += 1;
                    None
                }
            };
            return true;
        }
        // A keyframe part-way in.
        if let Some(c) = self.adding {
            self.adding = self.insert_part(clouds, maps, maps.active(), c);
            if self.adding.is_none() {
                self.counters.keyframes_inserted += 1;
                self.since_rebuild += 1;
            }
            return true;
        }
        // The map is full: rebuild it from the region around the rover.
        if maps.stats().cells >= self.keep_cells && self.since_rebuild > 0 {
            self.bounded = true;
            self.counters.regions_kept += 1;
            self.start_rebuild(clouds, maps);
            return true;
        }
        let store = clouds;
        // The graph moved: re-project everything if a keyframe moved far.
        if store.generation() != self.generation_seen {
            self.generation_seen = store.generation();
            if self.moved(clouds) {
                self.counters.reprojections_started += 1;
                self.start_rebuild(clouds, maps);
                return true;
            }
        }
        // The next keyframe, once it has its pose.
        let k = self.inserted.len();
        if k < store.ready() {
            let Some(pose) = store.pose(k) else {
                return false;
            };
            push_bounded(&mut self.inserted, *pose);
            let active = maps.active();
            self.adding = self.insert_part(clouds, maps, active, Cursor { k, point: 0 });
            if self.adding.is_none() {
                self.counters.keyframes_inserted += 1;
                self.since_rebuild += 1;
            }
            return true;
        }
        false
    }
}

impl MapBuilder {
    /// Start inserting every keyframe again into the spare map, keeping to
    /// the region around the newest keyframe once the maps are bounded.
    fn start_rebuild(&mut self, clouds: &KeyframeClouds, maps: &mut SurfaceMaps) {
        let store = clouds;
        let newest = store.ready().checked_sub(1).and_then(|k| store.pose(k));
        self.region = match newest {
            Some(p) if self.bounded => Some([p.t.x, p.t.y]),
            _ => None,
        };
        let spare = 1 - maps.active();
        maps.map_mut(spare).clear();
        self.rebuilt.clear();
        self.rebuilding = Some(Cursor { k: 0, point: 0 });
    }
}

/// Push without growing (the vectors are sized for every keyframe).
fn push_bounded(v: &mut Vec<Pose>, p: Pose) {
    if v.len() < v.capacity() {
        v.push(p);
    }
}
