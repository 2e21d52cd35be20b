//! Registration where the surfaces do not hold every direction: on the
//! simulated garage's bare roof two HDL-32E scans a metre apart read as no
//! motion at all (each ring pairs with itself), with the information of a
//! well-held direction. `registration::degeneracy` finds those directions
//! (the normals carry little of their information), keeps the guess there
//! and claims nothing; on a walled level and along the lava tube it
//! changes nothing.

mod common;

use common::{scan, sensor_pose, SENSOR_HEIGHT_M};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use speleo_slam::graph_slam::SlamParams;
use speleo_slam::registration::degeneracy::{keep_guess_where_unheld, surface_shares};
use speleo_slam::registration::{align, Alignment, GicpParams, PreparedCloud};
use speleo_twin::lidar::LidarWorld;
use speleo_twin::noise::Noise;

/// The share that tells the roof's directions (0.23 at most) from the lava
/// tube's axis (0.60 at least); `SlamParams::min_surface_share` is 0 (off)
/// by default, see the SLAM README.
const MIN_SHARE: f64 = 0.5;

/// A pair of scans registered as the keyframe pipeline does (a wide pass
/// from an odometry guess that over-reads by 5%, then a refining one),
/// with the truth and the guess.
struct Pair {
    fine: Alignment,
    guess: Isometry3<f64>,
    truth: Isometry3<f64>,
}

fn register(
    world: &LidarWorld,
    from: &Isometry3<f64>,
    to: &Isometry3<f64>,
    noise: &mut Noise,
) -> Pair {
    let slam = SlamParams::default();
    let refine = GicpParams {
        max_correspondence_m: slam.refine_distance_m,
        mutual: slam.refine_mutual,
        surface_information: true,
        ..slam.gicp
    };
    let mut a = PreparedCloud::with_capacity(slam.max_scan_points);
    let mut b = PreparedCloud::with_capacity(slam.max_scan_points);
    a.prepare(scan(world, from, slam.max_range_m, noise), slam.voxel_m);
    b.prepare(scan(world, to, slam.max_range_m, noise), slam.voxel_m);
    let truth = from.inverse() * to;
    let guess = Isometry3::from_parts(
        Translation3::from(truth.translation.vector * 1.05),
        truth.rotation,
    );
    let wide = align(&b, &a, &guess, &slam.gicp);
    let fine = align(&b, &a, &wide.transform, &refine);
    Pair { fine, guess, truth }
}

fn at(x: f64, y: f64, z: f64, yaw_deg: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(x, y, z + SENSOR_HEIGHT_M),
        UnitQuaternion::from_euler_angles(0.0, 0.0, yaw_deg.to_radians()),
    )
}

/// Translation error along the motion, m (positive: read long).
fn along(p: &Pair, tf: &Isometry3<f64>) -> f64 {
    let t = p.truth.translation.vector;
    (tf.translation.vector - t).dot(&t.normalize())
}

#[test]
fn on_a_bare_roof_the_guess_is_kept_along_the_plane_and_weighs_nothing() {
    let garage = speleo_twin::world::garage::generate();
    let Ok(world) = LidarWorld::new(&garage.mesh) else {
        panic!("the garage is not a ray-castable mesh");
    };
    let min_share = MIN_SHARE;
    let mut noise = Noise::new(7, 1);
    // Along x, along y and across, on the roof's south half (no opening
    // within the scans' 10 m).
    for (x, y, dx, dy, yaw) in [
        (4.0, 4.0, 1.0, 0.0, 0.0),
        (10.0, 2.0, 0.0, 1.0, 90.0),
        (4.0, 2.0, 0.7, 0.7, 45.0),
    ] {
        let p = register(
            &world,
            &at(x, y, 9.0, yaw),
            &at(x + dx, y + dy, 9.0, yaw),
            &mut noise,
        );
        let read = along(&p, &p.fine.transform);
        let Some((shares, _)) = surface_shares(&p.fine) else {
            panic!("no Hessian on the roof");
        };
        eprintln!("roof from ({x}, {y}): the normals' shares {shares:.3?}");
        // x, y and yaw: the rings carry most of it; z, roll, pitch: the
        // normals carry it all.
        assert!(shares[2] < 0.3 && shares[3] > 0.99, "{shares}");
        let mut kept = p.fine;
        let (unheld, _) = keep_guess_where_unheld(&mut kept, &p.guess, min_share);
        let now = along(&p, &kept.transform);
        eprintln!("roof from ({x}, {y}): GICP read {read:+.3} m along, kept {now:+.3} m ({unheld} unheld)");
        // GICP alone: the motion read as (almost) none.
        assert!(read < -0.8, "{read}");
        // x, y and yaw: the guess (5% long), and no information there.
        assert_eq!(unheld, 3);
        assert!((now - 0.05 * dx.hypot(dy)).abs() < 0.01, "{now}");
        // The information along the plane: what GICP claimed, left only
        // where x and y move with roll and pitch (a tilt about the sensor
        // slides the ground's points), which the normals hold.
        let planar = |h: &nalgebra::Matrix6<f64>| h[(0, 0)] + h[(1, 1)];
        let (before, after) = (planar(&p.fine.hessian), planar(&kept.hessian));
        eprintln!("  information along the plane: {before:.0} -> {after:.0}");
        assert!(after < 0.2 * before, "{before} -> {after}");
        // Height, roll and pitch stay the scans' own.
        assert!(kept.hessian[(2, 2)] > 1e3, "{}", kept.hessian);
    }
    // A walled level: every direction held, nothing changed.
    let p = register(
        &world,
        &at(3.0, 4.0, 6.0, 0.0),
        &at(4.0, 4.0, 6.0, 0.0),
        &mut noise,
    );
    let Some((shares, _)) = surface_shares(&p.fine) else {
        panic!("no Hessian on level 2");
    };
    assert!(shares[0] > 0.95, "{shares}");
    let mut kept = p.fine;
    assert_eq!(keep_guess_where_unheld(&mut kept, &p.guess, min_share).0, 0);
    assert_eq!(kept.transform, p.fine.transform);
    assert!(along(&p, &kept.transform).abs() < 5e-3);
}

#[test]
fn along_the_lava_tube_every_direction_is_held() {
    use speleo_twin::world::lava_tube::{generate, LavaTubeParams};
    let tube = generate(1, &LavaTubeParams::default());
    let Ok(world) = LidarWorld::new(&tube.mesh) else {
        panic!("the tube is not a ray-castable mesh");
    };
    let min_share = MIN_SHARE;
    let mut noise = Noise::new(7, 1);
    let pose = |i: usize| sensor_pose(&tube.route, i);
    let mut weakest = f64::INFINITY;
    for i in (5..tube.route.len() - 2).step_by(8) {
        let p = register(&world, &pose(i), &pose(i + 1), &mut noise);
        let Some((shares, _)) = surface_shares(&p.fine) else {
            panic!("no Hessian at route point {i}");
        };
        weakest = weakest.min(shares[0]);
        let mut kept = p.fine;
        assert_eq!(
            keep_guess_where_unheld(&mut kept, &p.guess, min_share).0,
            0,
            "route point {i}"
        );
    }
    eprintln!("lava tube: the normals' smallest share {weakest:.2} (threshold {min_share})");
    assert!(weakest > min_share + 0.05, "{weakest}");
}
