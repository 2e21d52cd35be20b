//! The multi-level surface map as an anytime task. Each step inserts at
//! most `maps.points_per_step` points: the next part of a new keyframe's
//! cloud at its optimised pose, or of a re-projection. When the pose graph
//! has moved a keyframe already in the map by more than `reproject_m` or
//! `reproject_deg` (a loop closure), every keyframe is inserted again at its
//! new pose into the second map while the first keeps serving; the two
//! swap when it is complete.
//!
//! The maps are bounded: once the serving map holds `keep_cells` cells, it
//! is rebuilt the same way from the points within `keep_radius_m` of the
//! rover (in the plane), and from then on every rebuild keeps to the
//! region around the rover. A rebuild is cut into the same steps as any
//! insertion, so keeping the region costs no longer step than mapping.

use speleo_mapping::mls::ExpectedGround;
use speleo_scheduler::{Context, StepResult, Task};
use speleo_slam::lie::{log_so3, Pose};

use crate::bus::Bus;
use crate::config::MapsConfig;

/// How far the LiDAR may sit from the base, m (clouds are in the base
/// frame, their range counted from the sensor).
const MOUNT_REACH_M: f64 = 2.0;

/// What the task has done.
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

pub struct MapsTask {
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

impl MapsTask {
    /// The task for `keyframes` keyframes, as `[maps]` configures it; the
    /// maps themselves are the bus's (`SurfaceMaps::new(cfg.mls_params())`).
    pub fn new(cfg: &MapsConfig, keyframes: usize) -> Result<Self, speleo_mapping::ParamsError> {
        let params = cfg.mls_params();
        let points_per_step = cfg.points_per_step.max(1);
        let (reproject_m, reproject_deg) = (cfg.reproject_m, cfg.reproject_deg);
        let keep_radius_m = cfg.mls_keep_radius_m;
        Ok(MapsTask {
            cloud_reach_m: cfg.range_m + MOUNT_REACH_M,
            // Room for one more step of points in new cells.
            keep_cells: params.max_cells.saturating_sub(points_per_step),
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
        })
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
    fn moved(&self, bus: &Bus) -> bool {
        self.inserted.iter().enumerate().any(|(k, at)| {
            bus.keyframe_clouds.pose(k).is_some_and(|now| {
                let d = at.between(now);
                d.t.norm() > self.reproject_m || log_so3(&d.r).norm() > self.reproject_rad
            })
        })
    }

    /// Insert the next part of keyframe `c.k` into map `m`; returns the
    /// cursor to go on from, or `None` when the keyframe is done.
    fn insert_part(&mut self, bus: &mut Bus, m: usize, c: Cursor) -> Option<Cursor> {
        let store = &bus.keyframe_clouds;
        let pose = *store.pose(c.k)?;
        let n = store.cloud(c.k).len();
        if c.point >= n && self.expected_ground.is_some() {
            return self.mark_part(bus, m, c, n);
        }
        self.scratch.clear();
        let cloud = bus.keyframe_clouds.cloud(c.k);
        let keeps = self.keeps(bus, m);
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
        let stats = bus
            .surface
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
    fn mark_part(&mut self, bus: &mut Bus, m: usize, c: Cursor, n: usize) -> Option<Cursor> {
        let pose = bus.keyframe_clouds.pose(c.k)?.to_isometry();
        let g = self.expected_ground.as_ref()?;
        let map = bus.surface.map_mut(m);
        let at = c.point - n;
        if at == 0 {
            self.mark_lift = g.lift(map, &pose);
            return Some(Cursor {
                k: c.k,
                point: c.point + 1,
            });
        }
        let keep = self.keeps(bus, m);
        let from = (at - 1) * MARK_AZIMUTHS_PER_STEP;
        let to = (from + MARK_AZIMUTHS_PER_STEP).min(g.azimuths());
        let map = bus.surface.map_mut(m);
        let marks = g.mark_azimuths(map, &pose, self.mark_lift, from..to, keep);
        self.counters.unseen_ground_marks += marks as u64;
        (to < g.azimuths()).then_some(Cursor {
            k: c.k,
            point: c.point + 1,
        })
    }

    /// Whether a point at `x, y` goes into map `m`: the active map takes
    /// everything, a map being rebuilt only what lies in the kept region.
    fn keeps(&self, bus: &Bus, m: usize) -> impl Fn(f64, f64) -> bool {
        let region = if m == bus.surface.active() {
            None
        } else {
            self.region
        };
        let r2 = self.keep_radius_m * self.keep_radius_m;
        move |x: f64, y: f64| {
            region.is_none_or(|[cx, cy]| (x - cx).powi(2) + (y - cy).powi(2) <= r2)
        }
    }

    /// One bounded unit of work; false when there is none.
    fn work(&mut self, bus: &mut Bus) -> bool {
        // A re-projection under way: the next part into the other map.
        if let Some(c) = self.rebuilding {
            let spare = 1 - bus.surface.active();
            let Some(pose) = bus.keyframe_clouds.pose(c.k) else {
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
                self.insert_part(bus, spare, c)
            };
            self.rebuilding = match next {
                Some(next) => Some(next),
                None if c.k + 1 < bus.keyframe_clouds.ready() => Some(Cursor {
                    k: c.k + 1,
                    point: 0,
                }),
                None => {
                    // Complete: the rebuilt map serves.
                    bus.surface.swap();
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
            self.adding = self.insert_part(bus, bus.surface.active(), c);
            if self.adding.is_none() {
                self.counters.keyframes_inserted += 1;
                self.since_rebuild += 1;
            }
            return true;
        }
        // The map is full: rebuild it from the region around the rover.
        if bus.surface.stats().cells >= self.keep_cells && self.since_rebuild > 0 {
            self.bounded = true;
            self.counters.regions_kept += 1;
            self.start_rebuild(bus);
            return true;
        }
        let store = &bus.keyframe_clouds;
        // The graph moved: re-project everything if a keyframe moved far.
        if store.generation() != self.generation_seen {
            self.generation_seen = store.generation();
            if self.moved(bus) {
                self.counters.reprojections_started += 1;
                self.start_rebuild(bus);
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
            let active = bus.surface.active();
            self.adding = self.insert_part(bus, active, Cursor { k, point: 0 });
            if self.adding.is_none() {
                self.counters.keyframes_inserted += 1;
                self.since_rebuild += 1;
            }
            return true;
        }
        false
    }
}

impl MapsTask {
    /// Start inserting every keyframe again into the spare map, keeping to
    /// the region around the newest keyframe once the maps are bounded.
    fn start_rebuild(&mut self, bus: &mut Bus) {
        let store = &bus.keyframe_clouds;
        let newest = store.ready().checked_sub(1).and_then(|k| store.pose(k));
        self.region = match newest {
            Some(p) if self.bounded => Some([p.t.x, p.t.y]),
            _ => None,
        };
        let spare = 1 - bus.surface.active();
        bus.surface.map_mut(spare).clear();
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

impl Task<Bus> for MapsTask {
    fn run(&mut self, _bus: &mut Bus, _cx: &Context) {}

    fn step(&mut self, bus: &mut Bus, _cx: &Context, quantum: u32) -> StepResult {
        for _ in 0..quantum.max(1) {
            if !self.work(bus) {
                return StepResult::Idle;
            }
        }
        StepResult::Continue
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::keyframe_clouds::KeyframeClouds;
    use crate::surface_maps::SurfaceMaps;
    use nalgebra::{Matrix3, Vector3};

    fn at(x: f64, z: f64) -> Pose {
        Pose::new(Matrix3::identity(), Vector3::new(x, 0.0, z))
    }

    /// A 1 m square of floor, 2 cm apart, 0.2 m below the base.
    fn floor(store: &mut KeyframeClouds) {
        assert!(store.begin());
        for i in 0..50 {
            for j in 0..50 {
                store.push([i as f64 * 0.02, j as f64 * 0.02, -0.2]);
            }
        }
        store.commit();
    }

    fn run_to_idle(t: &mut MapsTask, bus: &mut Bus) -> usize {
        let mut steps = 0;
        while t.work(bus) {
            steps += 1;
            assert!(steps < 10_000, "never idle");
        }
        steps
    }

    fn height(bus: &Bus, x: f64) -> Option<f32> {
        let m = bus.surface.serving();
        let (ix, iy) = m.cell_of(x, 0.5);
        m.cell(ix, iy).first().map(|p| p.mean)
    }

    #[test]
    fn keyframes_go_in_at_their_poses_and_are_reprojected_when_the_graph_moves_them() {
        let mut bus = Bus::new();
        bus.keyframe_clouds = KeyframeClouds::new(4, 4096);
        let cfg = MapsConfig {
            mls_max_cells: 4096,
            points_per_step: 1000,
            reproject_m: 0.05,
            reproject_deg: 0.5,
            ..MapsConfig::default()
        };
        let mut t = MapsTask::new(&cfg, 4).unwrap_or_else(|e| panic!("{e}"));
        bus.surface = SurfaceMaps::new(cfg.mls_params()).unwrap_or_else(|e| panic!("{e}"));
        floor(&mut bus.keyframe_clouds);
        floor(&mut bus.keyframe_clouds);
        // No pose yet: nothing to do.
        assert_eq!(run_to_idle(&mut t, &mut bus), 0);
        bus.keyframe_clouds.set_poses([at(0.0, 0.0), at(2.0, 0.0)]);
        // 2 x 2500 points, 1000 a step.
        assert_eq!(run_to_idle(&mut t, &mut bus), 6);
        assert_eq!(t.counters.keyframes_inserted, 2);
        assert_eq!(t.counters.points_inserted, 5000);
        assert!((height(&bus, 2.5).unwrap_or(f32::NAN) + 0.2).abs() < 1e-3);
        // A small correction: no re-projection.
        bus.keyframe_clouds.set_poses([at(0.0, 0.0), at(2.0, 0.01)]);
        assert_eq!(run_to_idle(&mut t, &mut bus), 0);
        // A loop closure lifts the second keyframe 0.3 m: every keyframe
        // goes in again, into the other map, which then serves.
        bus.keyframe_clouds.set_poses([at(0.0, 0.0), at(2.0, 0.3)]);
        let before = bus.surface.active();
        assert_eq!(run_to_idle(&mut t, &mut bus), 7);
        assert_eq!(t.counters.reprojections, 1);
        assert_ne!(bus.surface.active(), before);
        assert!((height(&bus, 2.5).unwrap_or(f32::NAN) - 0.1).abs() < 1e-3);
        assert!((height(&bus, 0.5).unwrap_or(f32::NAN) + 0.2).abs() < 1e-3);
        // A third keyframe arrives and goes into the serving map.
        floor(&mut bus.keyframe_clouds);
        bus.keyframe_clouds
            .set_poses([at(0.0, 0.0), at(2.0, 0.3), at(4.0, 0.0)]);
        run_to_idle(&mut t, &mut bus);
        assert_eq!(t.counters.keyframes_inserted, 3);
        assert!((height(&bus, 4.5).unwrap_or(f32::NAN) + 0.2).abs() < 1e-3);
    }

    #[test]
    fn the_rim_of_a_roof_a_keyframe_should_have_seen_past_is_marked_in_both_maps() {
        // Ground 0.2 m under the base from 2 m behind the rover to 1.2 m
        // ahead of it, nothing past that (a roof's rim with nothing seen
        // under it); rings meet that plane from 0.9 m out.
        let mut bus = Bus::new();
        bus.keyframe_clouds = KeyframeClouds::new(2, 40_000);
        let cfg = MapsConfig {
            mls_max_cells: 8192,
            ..MapsConfig::default()
        };
        let mount = nalgebra::Isometry3::translation(0.0, 0.0, 0.35);
        let elevations = speleo_hal::hdl32e::calib::NOMINAL_ELEVATION_DEG;
        let g = ExpectedGround::new(&mount, &elevations, -0.2, 1.6, 360);
        let mut t = MapsTask::new(&cfg, 2)
            .unwrap_or_else(|e| panic!("{e}"))
            .with_sensor_at([0.0, 0.0, 0.35])
            .with_expected_ground(g);
        bus.surface = SurfaceMaps::new(cfg.mls_params()).unwrap_or_else(|e| panic!("{e}"));
        assert!(bus.keyframe_clouds.begin());
        for i in 0..160 {
            for j in 0..120 {
                let (x, y) = (-2.0 + i as f64 * 0.02 + 0.01, -1.2 + j as f64 * 0.02 + 0.01);
                bus.keyframe_clouds.push([x, y, -0.2]);
            }
        }
        bus.keyframe_clouds.commit();
        bus.keyframe_clouds.set_poses([at(0.0, 0.0)]);
        // 19,200 points 4,000 a step, the ground's lift, then 360
        // azimuths of marks 40 a step.
        assert_eq!(run_to_idle(&mut t, &mut bus), 5 + 1 + 9);
        assert!(t.counters.unseen_ground_marks > 0);
        let unseen = |bus: &Bus, x: f64, y: f64| {
            let m = bus.surface.serving();
            let (ix, iy) = m.cell_of(x, y);
            m.unseen_ground(ix, iy)
        };
        assert!(unseen(&bus, 1.35, 0.05).is_some_and(|u| (u + 0.2).abs() < 1e-3));
        assert_eq!(unseen(&bus, 1.0, 0.05), None, "on the roof");
        assert_eq!(
            unseen(&bus, 1.35, 1.5),
            None,
            "beyond the roof's side, no ray"
        );
        // A loop closure re-projects the keyframe into the other map.
        bus.keyframe_clouds.set_poses([at(0.0, 0.3)]);
        let before = bus.surface.active();
        run_to_idle(&mut t, &mut bus);
        assert_ne!(bus.surface.active(), before);
        assert!(unseen(&bus, 1.35, 0.05).is_some_and(|u| (u - 0.1).abs() < 1e-3));
    }

    #[test]
    fn a_full_map_is_rebuilt_from_the_region_around_the_rover_and_never_grows() {
        // Ten keyframes of 1 m squares of floor (100 cells each), 3 m
        // apart along x; the map holds 500 cells less a step's 100, so it
        // fills at the fourth and keeps the 4 m around the newest keyframe
        // (its floor and the previous one's) from then on.
        let mut bus = Bus::new();
        bus.keyframe_clouds = KeyframeClouds::new(10, 4096);
        let cfg = MapsConfig {
            mls_max_cells: 500,
            mls_keep_radius_m: 4.0,
            points_per_step: 100,
            range_m: 1.0,
            ..MapsConfig::default()
        };
        let mut t = MapsTask::new(&cfg, 10).unwrap_or_else(|e| panic!("{e}"));
        bus.surface = SurfaceMaps::new(cfg.mls_params()).unwrap_or_else(|e| panic!("{e}"));
        let mut poses = Vec::new();
        for k in 0..10 {
            floor(&mut bus.keyframe_clouds);
            poses.push(at(3.0 * k as f64, 0.0));
            bus.keyframe_clouds.set_poses(poses.iter().copied());
            run_to_idle(&mut t, &mut bus);
            let s = bus.surface.stats();
            assert!(s.cells <= 500 && s.dropped_points == 0, "{s:?}");
            // The newest keyframe's floor is always in the serving map.
            assert!(height(&bus, 3.0 * k as f64 + 0.5).is_some(), "keyframe {k}");
        }
        assert_eq!(t.counters.regions_kept, 4, "{:?}", t.counters);
        assert!(t.counters.points_outside_region > 0);
        // The first keyframe's floor is long gone; the last two stay.
        assert!(height(&bus, 0.5).is_none());
        assert!(height(&bus, 24.5).is_some() && height(&bus, 27.5).is_some());
        assert_eq!(t.counters.keyframes_inserted, 10);
    }
}
