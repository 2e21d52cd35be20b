//! The physics rover (speleo-physics) driven in the twin's worlds: standing,
//! driving, turning and falling on flat ground, climbing a slope, and the
//! same motion bit for bit in the lava tube.

use speleo_physics::body::{BodyState, GRAVITY, WHEELS};
use speleo_physics::rover::{PhysicsParams, PhysicsRover};
use speleo_physics::terrain::{Material, Mesh};
use speleo_twin::rover::wrap_angle;
use speleo_twin::world::World;

fn drive(world: &World, targets: [f64; WHEELS], seconds: f64) -> (BodyState, BodyState) {
    let mut r = PhysicsRover::new(&PhysicsParams::default(), &world.mesh, world.start, 0.001)
        .expect("rover");
    // Settle on the ground first.
    for k in 0..500u64 {
        r.step(k * 1_000_000, &[0.0; WHEELS]);
    }
    let settled = *r.state();
    let n = (seconds * 1000.0) as u64;
    for k in 0..n {
        r.step((500 + k) * 1_000_000, &targets);
    }
    (settled, *r.state())
}

#[test]
fn the_rover_stands_on_flat_ground() {
    let w = World::build("flat", 0).expect("flat");
    let (settled, _) = drive(&w, [0.0; WHEELS], 0.5);
    let p = PhysicsParams::default();
    // Resting on its legs: the hub is between the leg length and its
    // projection at the worst phase (cos 36 deg for five legs).
    let z = settled.position[2];
    assert!(
        z > p.wheel_radius_m * 0.75 && z < p.wheel_radius_m + 0.01,
        "{z}"
    );
    let (_, pitch, roll) = settled.ypr();
    assert!(pitch.abs() < 0.1 && roll.abs() < 0.05, "{pitch} {roll}");
    // The accelerometer reads +g up at rest.
    assert!(
        (settled.specific_force[2] - GRAVITY).abs() < 0.5,
        "{:?}",
        settled.specific_force
    );
}

#[test]
fn equal_wheel_speeds_drive_forward_and_opposite_ones_turn() {
    let w = World::build("flat", 0).expect("flat");
    let (a, b) = drive(&w, [2.0; WHEELS], 3.0);
    let dx = b.position[0] - a.position[0];
    let dy = b.position[1] - a.position[1];
    // About 0.38 m/s at the rim (less on legs that slip).
    assert!(dx > 0.6 && dx < 1.3, "{dx}");
    assert!(dy.abs() < 0.15 * dx, "{dy}");
    assert!(
        b.wheel_speed.iter().all(|s| (s - 2.0).abs() < 0.3),
        "{:?}",
        b.wheel_speed
    );
    assert!(
        b.wheel_angle.iter().all(|a| *a > 4.0),
        "{:?}",
        b.wheel_angle
    );
    let (a, b) = drive(&w, [-1.5, 1.5, -1.5, 1.5], 2.0);
    let turned = wrap_angle(b.yaw() - a.yaw());
    assert!(turned > 0.3, "{turned}");
}

/// The rover let go `h` metres over flat ground, then driven 2 s.
fn dropped(h: f64) -> (PhysicsRover, BodyState) {
    let w = World::build("flat", 0).expect("flat");
    let [x, y, z, yaw] = w.start;
    let mut r = PhysicsRover::new(
        &PhysicsParams::default(),
        &w.mesh,
        [x, y, z + h, yaw],
        0.001,
    )
    .expect("rover");
    for k in 0..1500u64 {
        r.step(k * 1_000_000, &[0.0; WHEELS]);
    }
    let landed = *r.state();
    for k in 1500..3500u64 {
        r.step(k * 1_000_000, &[3.0; WHEELS]);
    }
    (r, landed)
}

#[test]
fn a_fall_is_counted_and_a_high_one_wrecks_the_rover_where_it_struck() {
    // A drop of 0.3 m sinks at 2.4 m/s: a step down, not a fall.
    let (r, _) = dropped(0.3);
    assert_eq!((r.falls, r.wrecked), (0, false));
    // 0.8 m: a fall, the rover drives on.
    let (r, landed) = dropped(0.8);
    assert_eq!((r.falls, r.wrecked), (1, false));
    assert!((r.worst_fall_m - 0.8).abs() < 0.15, "{}", r.worst_fall_m);
    assert!(r.state().position[0] - landed.position[0] > 0.3);
    // 3 m: wrecked at the strike, on the ground, and it stays there.
    let (r, landed) = dropped(3.0);
    assert_eq!((r.falls, r.wrecked), (1, true));
    assert!((r.worst_fall_m - 3.0).abs() < 0.15, "{}", r.worst_fall_m);
    let z = landed.position[2];
    assert!(z > 0.0 && z < 0.5, "{z}");
    assert_eq!(r.state().position, landed.position);
    assert_eq!(r.state().velocity, [0.0; 3]);
    // At rest, however it lies: the accelerometer reads g.
    let f = r.state().specific_force;
    assert!(((f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt() - GRAVITY).abs() < 1e-9);
}

#[test]
fn the_same_inputs_give_the_same_motion_bit_for_bit() {
    let w = World::build("lava-tube", 1).expect("tube");
    let (_, a) = drive(&w, [2.0, 2.5, 2.0, 2.5], 1.0);
    let (_, b) = drive(&w, [2.0, 2.5, 2.0, 2.5], 1.0);
    assert_eq!(a, b);
}

#[test]
fn the_drives_work_lifts_the_rover_up_a_slope() {
    // Driven 4 s up a 15-degree slope: the work the drives' torques
    // did at their wheels' speeds is the rover's rise in potential
    // energy and the losses of legs striking and slipping.
    let p = PhysicsParams::default();
    let slope = 15f64.to_radians();
    let ground = grid_of(8.0, 0.1, |x, _| x * slope.tan());
    let start = [-3.0, 0.0, -3.0 * slope.tan(), 0.0];
    let mut r = PhysicsRover::new_tilted(&p, &ground, start, [-slope, 0.0], 0.01).expect("rover");
    let work = |r: &mut PhysicsRover, from: u64, steps: u64, target: f64| {
        let mut joules = 0.0;
        for k in from..from + steps {
            r.step(k * 10_000_000, &[target; WHEELS]);
            let s = r.state();
            joules += (0..WHEELS)
                .map(|w| s.wheel_torque[w] * s.wheel_speed[w] * 0.01)
                .sum::<f64>();
        }
        joules
    };
    work(&mut r, 0, 100, 0.0);
    let z0 = r.state().position[2];
    let joules = work(&mut r, 100, 400, 2.0);
    let mass = p.chassis_mass_kg + WHEELS as f64 * p.wheel_mass_kg;
    let lifted = mass * GRAVITY * (r.state().position[2] - z0);
    assert!(lifted > 30.0, "rose {lifted} J only");
    assert!(
        joules > lifted && joules < 1.8 * lifted,
        "{joules} J of work for {lifted} J lifted"
    );
    // Rolling on the flat takes far less.
    let w = World::build("flat", 0).expect("flat");
    let mut r = PhysicsRover::new(&p, &w.mesh, w.start, 0.01).expect("rover");
    work(&mut r, 0, 100, 0.0);
    let flat = work(&mut r, 100, 400, 2.0);
    assert!(flat > 0.0 && flat < 0.5 * joules, "{flat} J on the flat");
}

/// Ground `side` m square round the origin, of right triangles with legs of
/// `cell` m, at the height `z(x, y)`.
fn grid_of(side: f64, cell: f64, z: impl Fn(f64, f64) -> f64) -> Mesh {
    let n = (side / cell).round() as u32;
    let mut m = Mesh::default();
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (-side / 2.0 + i as f64 * cell, -side / 2.0 + j as f64 * cell);
            m.vertices.push([x as f32, y as f32, z(x, y) as f32]);
        }
    }
    for i in 0..n {
        for j in 0..n {
            let v = i * (n + 1) + j;
            let (a, b, c, d) = (v, v + 1, v + n + 1, v + n + 2);
            m.triangles.push([a, c, d]);
            m.triangles.push([a, d, b]);
            m.materials.extend([Material::Rock; 2]);
        }
    }
    m
}
