//! Ground a scan should have seen and did not: a roof's open edge is
//! marked, level ground, a wall's shadow and lower ground beyond a step
//! are not.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use speleo_hal::hdl32e::calib::NOMINAL_ELEVATION_DEG;
use speleo_mapping::mls::{ExpectedGround, MlsMap, MlsParams};

/// The base frame's origin over the ground, and the LiDAR over the base.
const BASE_Z: f64 = 0.171;
const MOUNT_Z: f64 = 0.35;

/// What a ray from the sensor meets first, if anything.
trait Scene {
    fn cast(&self, o: Vector3<f64>, u: Vector3<f64>) -> Option<Vector3<f64>>;
}

/// Ground at z = 0 for x under `edge` (a roof with nothing under it past
/// its rim), or at `beyond_z` past it when that is given.
struct Roof {
    edge: f64,
    beyond_z: Option<f64>,
}

impl Scene for Roof {
    fn cast(&self, o: Vector3<f64>, u: Vector3<f64>) -> Option<Vector3<f64>> {
        if u.z >= 0.0 {
            return None;
        }
        let top = o + u * (-o.z / u.z);
        if top.x <= self.edge {
            return Some(top);
        }
        let z = self.beyond_z?;
        let low = o + u * ((z - o.z) / u.z);
        Some(low)
    }
}

/// Level ground with a wall `h` high across x = `at`.
struct Wall {
    at: f64,
    h: f64,
}

impl Scene for Wall {
    fn cast(&self, o: Vector3<f64>, u: Vector3<f64>) -> Option<Vector3<f64>> {
        if u.x > 0.0 {
            let w = o + u * ((self.at - o.x) / u.x);
            if w.z >= 0.0 && w.z <= self.h {
                return Some(w);
            }
        }
        if u.z >= 0.0 {
            return None;
        }
        let g = o + u * (-o.z / u.z);
        (g.x < self.at).then_some(g)
    }
}

/// Level ground up to x = `at`, then falling away at `slope_deg`.
struct Crest {
    at: f64,
    slope_deg: f64,
}

impl Crest {
    fn z(&self, x: f64) -> f64 {
        -(x - self.at).max(0.0) * self.slope_deg.to_radians().tan()
    }
}

impl Scene for Crest {
    fn cast(&self, o: Vector3<f64>, u: Vector3<f64>) -> Option<Vector3<f64>> {
        if u.z >= 0.0 {
            return None;
        }
        let level = o + u * (-o.z / u.z);
        if level.x <= self.at || u.x <= 0.0 {
            return Some(level);
        }
        // o.z + t u.z = -(o.x + t u.x - at) k
        let k = self.slope_deg.to_radians().tan();
        let t = (-o.z - k * (o.x - self.at)) / (u.z + k * u.x);
        (t > 0.0).then(|| o + u * t)
    }
}

fn base() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(0.0, 0.0, BASE_Z),
        UnitQuaternion::identity(),
    )
}

fn expected() -> ExpectedGround {
    let mount = Isometry3::translation(0.0, 0.0, MOUNT_Z);
    ExpectedGround::new(&mount, &NOMINAL_ELEVATION_DEG, -BASE_Z, 1.6, 720)
}

/// One revolution of the 32 lasers every 0.2 degrees, into a fresh map.
fn scanned(scene: &dyn Scene) -> MlsMap {
    let mut m = MlsMap::new(MlsParams::default()).expect("valid parameters");
    let o = Vector3::new(0.0, 0.0, BASE_Z + MOUNT_Z);
    let mut pts = Vec::new();
    for a in 0..1800 {
        let az = (a as f64 * 0.2).to_radians();
        for e in NOMINAL_ELEVATION_DEG.iter().map(|e| e.to_radians()) {
            let u = Vector3::new(e.cos() * az.cos(), e.cos() * az.sin(), e.sin());
            if let Some(p) = scene.cast(o, u) {
                if (p - o).norm() < 30.0 {
                    pts.push([p.x, p.y, p.z]);
                }
            }
        }
    }
    m.insert_points_seen_from(&pts, o.z);
    m
}

fn marked_cells(m: &MlsMap) -> Vec<(i32, i32, f32)> {
    let mut v = Vec::new();
    m.for_each_cell(|ix, iy, _| {
        if let Some(z) = m.unseen_ground(ix, iy) {
            v.push((ix, iy, z));
        }
    });
    v
}

#[test]
fn the_rim_of_a_roof_with_nothing_seen_under_it_is_marked_at_the_roofs_height() {
    let roof = Roof {
        edge: 1.2,
        beyond_z: None,
    };
    let mut m = scanned(&roof);
    let marks = expected().mark(&mut m, &base(), |_, _| true);
    let cells = marked_cells(&m);
    assert!(marks > 0 && !cells.is_empty());
    let res = m.params().resolution_m;
    for &(ix, _, z) in &cells {
        assert!(ix as f64 * res >= 1.1, "a mark on the roof: cell {ix}");
        assert!(z.abs() < 0.01, "at the roof's height: {z}");
    }
    // Cells just past the rim ahead of the rover are marked.
    let (ex, ey) = m.cell_of(1.35, 0.02);
    assert!(m.unseen_ground(ex, ey).is_some(), "{cells:?}");
    // A return there later makes the mark moot.
    m.insert_points(&[[1.35, 0.02, -2.0]]);
    assert_eq!(m.unseen_ground(ex, ey), None);
    assert!(m.stats().unseen_marks >= marks as u64);
}

#[test]
fn a_rim_nearer_than_the_lowest_ring_is_marked_from_where_the_rover_stands() {
    // 0.6 m from the rim every ring already lands past it.
    let roof = Roof {
        edge: 0.6,
        beyond_z: None,
    };
    let mut m = scanned(&roof);
    assert!(expected().mark(&mut m, &base(), |_, _| true) > 0);
    let (ex, ey) = m.cell_of(0.95, 0.02);
    assert!(m.unseen_ground(ex, ey).is_some_and(|z| z.abs() < 0.01));
    assert!(marked_cells(&m).iter().all(|&(ix, _, _)| ix >= 6));
}

#[test]
fn marks_stand_at_the_seen_grounds_height_when_the_base_height_is_off() {
    // The model puts the ground 2 cm higher under the base than it is.
    let roof = Roof {
        edge: 1.2,
        beyond_z: None,
    };
    let mut m = scanned(&roof);
    let mount = Isometry3::translation(0.0, 0.0, MOUNT_Z);
    let g = ExpectedGround::new(&mount, &NOMINAL_ELEVATION_DEG, -BASE_Z + 0.02, 1.6, 720);
    assert!(g.mark(&mut m, &base(), |_, _| true) > 0);
    for (ix, _, u) in marked_cells(&m) {
        assert!(ix >= 11 && u.abs() < 0.005, "cell {ix} at {u}");
    }
}

#[test]
fn level_ground_all_round_is_never_marked() {
    let flat = Roof {
        edge: f64::INFINITY,
        beyond_z: None,
    };
    let mut m = scanned(&flat);
    assert_eq!(expected().mark(&mut m, &base(), |_, _| true), 0);
    assert!(marked_cells(&m).is_empty());
}

#[test]
fn nothing_is_marked_in_a_walls_shadow_or_past_a_step_down_to_seen_ground() {
    let wall = Wall { at: 0.8, h: 1.0 };
    let mut m = scanned(&wall);
    assert_eq!(expected().mark(&mut m, &base(), |_, _| true), 0);
    let step = Roof {
        edge: 1.2,
        beyond_z: Some(-0.5),
    };
    let mut m = scanned(&step);
    // Past the step the rays go on to the lower floor: cells between the
    // rim and where they land hold nothing, but nothing is at the plane's
    // height there, so a mark would be true; they are marked only after
    // level ground, at the plane's height.
    expected().mark(&mut m, &base(), |_, _| true);
    for (ix, _, z) in marked_cells(&m) {
        assert!(ix as f64 * 0.1 >= 1.1 && z.abs() < 0.01);
    }
}

#[test]
fn marks_follow_the_keep_region_and_survive_eviction_of_others() {
    let roof = Roof {
        edge: 1.2,
        beyond_z: None,
    };
    let mut m = scanned(&roof);
    let marks = expected().mark(&mut m, &base(), |_, y| y >= 0.0);
    assert!(marks > 0);
    assert!(marked_cells(&m).iter().all(|&(_, iy, _)| iy >= 0));
    let before = marked_cells(&m);
    m.keep_region([1.35, 0.05], 0.2);
    let after = marked_cells(&m);
    assert!(
        !after.is_empty() && after.len() < before.len(),
        "{before:?} {after:?}"
    );
    assert!(after.iter().all(|c| before.contains(c)));
}

#[test]
fn past_a_crest_no_mark_stands_where_the_ground_is_near_the_planes_height() {
    // Ground falling away past a crest stretches the rings apart: the
    // cells between them are empty, but the ground there is under the
    // plane's height, and a mark within 1.5 cm of it would make a drop of
    // ground the rover can drive (see the traversability's rule).
    let crests = [
        (0.6, 10.0),
        (1.0, 10.0),
        (1.2, 5.0),
        (0.9, 20.0),
        (1.0, 3.0),
        (1.3, 2.0),
        (0.95, 7.0),
    ];
    for (at, slope_deg) in crests {
        let crest = Crest { at, slope_deg };
        let mut m = scanned(&crest);
        expected().mark(&mut m, &base(), |_, _| true);
        for (ix, iy, u) in marked_cells(&m) {
            let [x, _] = m.cell_center(ix, iy);
            let ground = crest.z(x + 0.05) as f32;
            assert!(
                ground < u - 0.015,
                "crest at {at} m, {slope_deg} deg: cell {ix},{iy} marked at {u}, ground {ground}"
            );
        }
    }
}
