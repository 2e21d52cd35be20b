//! The map builder over keyframe clouds: insertion at the keyframes'
//! poses, re-projection when the graph moves them, the unseen-ground marks,
//! and the region kept when the map is full.

use nalgebra::{Matrix3, Vector3};
use speleo_mapping::mls::{ExpectedGround, MlsParams};
use speleo_mapping::{BuilderParams, KeyframeClouds, MapBuilder, SurfaceMaps};
use speleo_slam::lie::Pose;

/// The keyframe clouds and the maps the builder reads and writes.
struct Maps {
    keyframe_clouds: KeyframeClouds,
    surface: SurfaceMaps,
}

impl Maps {
    fn new(keyframes: usize, points: usize) -> Self {
        Maps {
            keyframe_clouds: KeyframeClouds::new(keyframes, points),
            surface: SurfaceMaps::empty(),
        }
    }
}

/// `[maps]`'s settings the tests vary, the rest at the rover's defaults.
struct Cfg {
    mls_max_cells: usize,
    mls_keep_radius_m: f64,
    points_per_step: usize,
    range_m: f64,
    reproject_m: f64,
    reproject_deg: f64,
}

impl Default for Cfg {
    fn default() -> Self {
        Cfg {
            mls_max_cells: 1 << 18,
            mls_keep_radius_m: 20.0,
            points_per_step: 4_000,
            range_m: 20.0,
            reproject_m: 0.05,
            reproject_deg: 0.5,
        }
    }
}

impl Cfg {
    fn mls(&self) -> MlsParams {
        MlsParams {
            max_cells: self.mls_max_cells,
            ..MlsParams::default()
        }
    }

    fn builder(&self, keyframes: usize) -> MapBuilder {
        let p = BuilderParams {
            points_per_step: self.points_per_step,
            reproject_m: self.reproject_m,
            reproject_deg: self.reproject_deg,
            keep_radius_m: self.mls_keep_radius_m,
            range_m: self.range_m,
        };
        MapBuilder::new(&p, self.mls_max_cells, keyframes)
    }
}

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

fn run_to_idle(t: &mut MapBuilder, bus: &mut Maps) -> usize {
    let mut steps = 0;
    while t.work(&bus.keyframe_clouds, &mut bus.surface) {
        steps += 1;
        assert!(steps < 10_000, "never idle");
    }
    steps
}

fn height(bus: &Maps, x: f64) -> Option<f32> {
    let m = bus.surface.serving();
    let (ix, iy) = m.cell_of(x, 0.5);
    m.cell(ix, iy).first().map(|p| p.mean)
}

#[test]
fn keyframes_go_in_at_their_poses_and_are_reprojected_when_the_graph_moves_them() {
    let mut bus = Maps::new(4, 4096);
    let cfg = Cfg {
        mls_max_cells: 4096,
        points_per_step: 1000,
        reproject_m: 0.05,
        reproject_deg: 0.5,
        ..Cfg::default()
    };
    let mut t = cfg.builder(4);
    bus.surface = SurfaceMaps::new(cfg.mls()).unwrap_or_else(|e| panic!("{e}"));
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
    let mut bus = Maps::new(2, 40_000);
    let cfg = Cfg {
        mls_max_cells: 8192,
        ..Cfg::default()
    };
    let mount = nalgebra::Isometry3::translation(0.0, 0.0, 0.35);
    let elevations = speleo_hal::hdl32e::calib::NOMINAL_ELEVATION_DEG;
    let g = ExpectedGround::new(&mount, &elevations, -0.2, 1.6, 360);
    let mut t = cfg
        .builder(2)
        .with_sensor_at([0.0, 0.0, 0.35])
        .with_expected_ground(g);
    bus.surface = SurfaceMaps::new(cfg.mls()).unwrap_or_else(|e| panic!("{e}"));
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
    let unseen = |bus: &Maps, x: f64, y: f64| {
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
    let mut bus = Maps::new(10, 4096);
    let cfg = Cfg {
        mls_max_cells: 500,
        mls_keep_radius_m: 4.0,
        points_per_step: 100,
        range_m: 1.0,
        ..Cfg::default()
    };
    let mut t = cfg.builder(10);
    bus.surface = SurfaceMaps::new(cfg.mls()).unwrap_or_else(|e| panic!("{e}"));
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
