//! Requirements O1-O10 (README.md).

use super::*;
use core::f64::consts::{FRAC_PI_2, PI};

fn params() -> OdometryParams {
    OdometryParams {
        wheel_radius_m: 0.2,
        counts_per_rev: 1000.0,
        max_step_m: 2.0,
        ..OdometryParams::default()
    }
}

const MS: u64 = 1_000_000;

fn imu(t_ms: u64, yaw_rate: f64) -> ImuInput {
    ImuInput {
        time_ns: t_ms * MS,
        gyro: [0.0, 0.0, yaw_rate],
        orientation: [1.0, 0.0, 0.0, 0.0],
    }
}

fn wxyz(q: &UnitQuaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}

/// A rover driving at `speed` (m/s) and `yaw_rate` (rad/s) with the given
/// device roll and pitch, for `seconds` at 100 Hz: one IMU sample then one
/// wheel step per 10 ms. `wheel_scale` multiplies each wheel's travel
/// (1: no slip). The skid-steer sides move at speed -+ yaw_rate * B chi / 2.
struct Drive {
    o: Odometry,
    t_ms: u64,
    wheel_m: [f64; 4],
    device_yaw: f64,
}

impl Drive {
    fn new(p: OdometryParams) -> Self {
        // A fine encoder: quantisation is not what these tests are about.
        let mut o = Odometry::new(OdometryParams {
            counts_per_rev: 16384.0,
            ..p
        });
        o.imu(&imu(0, 0.0));
        o.wheels(0, [0; 4]);
        Drive {
            o,
            t_ms: 0,
            wheel_m: [0.0; 4],
            device_yaw: 0.0,
        }
    }

    fn counts(&self) -> [i32; 4] {
        let p = self.o.params();
        let per_m = p.counts_per_rev / (2.0 * PI * p.wheel_radius_m);
        self.wheel_m.map(|m| (m * per_m).round() as i32)
    }

    fn run(&mut self, seconds: f64, speed: f64, yaw_rate: f64, rp: (f64, f64), scale: [f64; 4]) {
        let p = self.o.params().clone();
        let half = 0.5 * p.track_width_m * p.skid_factor;
        for _ in 0..(seconds * 100.0).round() as u64 {
            self.t_ms += 10;
            // The device's heading drifts; only its roll and pitch are used.
            self.device_yaw += 0.003;
            let q = rot::from_rpy(rp.0, rp.1, self.device_yaw);
            self.o.imu(&ImuInput {
                time_ns: self.t_ms * MS,
                gyro: [0.0, 0.0, yaw_rate],
                orientation: wxyz(&q),
            });
            let side = [
                speed - yaw_rate * half,
                speed + yaw_rate * half,
                speed - yaw_rate * half,
                speed + yaw_rate * half,
            ];
            for i in 0..4 {
                self.wheel_m[i] += side[i] * 0.01 * scale[i];
            }
            let c = self.counts();
            self.o.wheels(self.t_ms * MS, c);
        }
    }

    fn xyz(&self) -> Vector3<f64> {
        self.o.pose().translation.vector
    }
}

const NO_SLIP: [f64; 4] = [1.0; 4];

#[test]
fn o1_straight_line_equals_wheel_travel() {
    let mut o = Odometry::new(params());
    o.wheels(0, [0; 4]);
    // One revolution = 2 pi 0.2 m.
    o.wheels(10 * MS, [1000; 4]);
    let t = o.pose().translation.vector;
    assert!((t.x - 2.0 * PI * 0.2).abs() < 1e-12);
    assert!(t.y.abs() < 1e-12 && t.z.abs() < 1e-12);
    assert_eq!(o.counters().slip_steps, 0);

    let mut d = Drive::new(params());
    d.run(10.0, 0.5, 0.0, (0.0, 0.0), NO_SLIP);
    let t = d.xyz();
    assert!((t.x - 5.0).abs() < 2e-3 && t.y.abs() < 1e-9, "{t}");
    assert!((d.o.distance_m() - 5.0).abs() < 2e-3);
    assert_eq!(d.o.counters().slip_steps, 0);
    assert_eq!(d.o.counters().yaw_mismatches, 0);
}

#[test]
fn o2_quarter_turn_then_forward_goes_left() {
    let mut o = Odometry::new(params());
    o.imu(&imu(0, 0.0));
    for k in 1..=100 {
        o.imu(&imu(k * 10, FRAC_PI_2));
    }
    o.wheels(1000 * MS, [0; 4]);
    o.wheels(1010 * MS, [1000; 4]);
    let t = o.pose().translation.vector;
    assert!(t.x.abs() < 1e-9, "{t}");
    assert!((t.y - 1.2566370614359172).abs() < 1e-9, "{t}");
}

#[test]
fn o2_driving_an_arc_follows_the_circle_without_slip() {
    // 0.4 m/s at 0.2 rad/s: a circle of radius 2 m; half of it in pi/0.2 s.
    let mut d = Drive::new(params());
    d.run(PI / 0.2, 0.4, 0.2, (0.0, 0.0), NO_SLIP);
    let t = d.xyz();
    assert!(t.x.abs() < 0.01 && (t.y - 4.0).abs() < 0.01, "{t}");
    let (_, _, yaw) = rot::to_rpy(&d.o.pose().rotation);
    assert!((yaw.abs() - PI).abs() < 1e-3, "{yaw}");
    assert!((d.o.distance_m() - 2.0 * PI).abs() < 0.01);
    assert_eq!(d.o.counters().slip_steps, 0);
    assert_eq!(d.o.counters().yaw_mismatches, 0);
    // Turning on the spot: no travel, no slip.
    let before = d.xyz();
    d.run(2.0, 0.0, 0.5, (0.0, 0.0), NO_SLIP);
    assert!((d.xyz() - before).norm() < 1e-3);
    assert_eq!(d.o.counters().slip_steps, 0);
}

#[test]
fn o3_encoder_wrap_and_glitches() {
    let mut o = Odometry::new(params());
    o.wheels(0, [i32::MAX - 5; 4]);
    let d = o.wheels(10 * MS, [i32::MIN + 4; 4]);
    assert!((d - 10.0 * 2.0 * PI * 0.2 / 1000.0).abs() < 1e-12);
    // Every wheel jumps: the step is ignored.
    assert_eq!(o.wheels(20 * MS, [10_000; 4]), 0.0);
    assert_eq!(o.counters().rejected_steps, 1);
    assert_eq!(o.counters().wheel_glitches, [1; 4]);
    // One wheel jumps (a drive rebooted): the others carry the step.
    let d = o.wheels(30 * MS, [10_010, 10_010, -5_000_000, 10_010]);
    assert!((d - 10.0 * 2.0 * PI * 0.2 / 1000.0).abs() < 1e-12, "{d}");
    assert_eq!(o.counters().wheel_glitches, [1, 1, 2, 1]);
    assert_eq!(o.counters().rejected_steps, 1);
}

#[test]
fn o4_climbing_a_slope_gains_height_from_the_imu_pitch() {
    // 15 deg nose up (pitch is about y, nose down positive).
    let slope = 15f64.to_radians();
    let mut d = Drive::new(params());
    // Climbing starts after the filter has settled on the slope.
    d.run(8.0, 0.0, 0.0, (0.0, -slope), NO_SLIP);
    d.run(20.0, 0.5, 0.0, (0.0, -slope), NO_SLIP);
    let t = d.xyz();
    assert!((t.x - 10.0 * slope.cos()).abs() < 0.02, "{t}");
    assert!((t.z - 10.0 * slope.sin()).abs() < 0.02, "{t}");
    assert!(t.y.abs() < 1e-9, "{t}");
    // Down again, rolled a little: back where it started.
    d.run(20.0, -0.5, 0.0, (0.05, -slope), NO_SLIP);
    assert!(d.xyz().norm() < 0.02, "{}", d.xyz());
}

#[test]
fn o5_a_spinning_or_stuck_wheel_is_left_out() {
    // Front left spins at three times the ground speed.
    let mut d = Drive::new(params());
    d.run(10.0, 0.4, 0.0, (0.0, 0.0), [3.0, 1.0, 1.0, 1.0]);
    let t = d.xyz();
    assert!((t.x - 4.0).abs() < 0.01 && t.y.abs() < 1e-9, "{t}");
    assert!((d.o.distance_m() - 4.0).abs() < 0.01);
    let c = *d.o.counters();
    assert!(c.wheel_slips[0] >= 990, "{c:?}");
    assert_eq!(c.wheel_slips[1..], [0, 0, 0]);
    assert_eq!(c.slip_events, 1, "{c:?}");
    assert!(c.yaw_mismatches > 900, "{c:?}");
    assert!(d.o.slipping());

    // Rear right stalls while the rover turns.
    let mut d = Drive::new(params());
    d.run(PI / 0.2, 0.4, 0.2, (0.0, 0.0), [1.0, 1.0, 1.0, 0.0]);
    let t = d.xyz();
    assert!(t.x.abs() < 0.02 && (t.y - 4.0).abs() < 0.02, "{t}");
    assert!(d.o.counters().wheel_slips[3] > 1500);
    assert_eq!(d.o.counters().wheel_slips[..3], [0, 0, 0]);

    // A brief spin: two events, the distance still right.
    let mut d = Drive::new(params());
    d.run(2.0, 0.4, 0.0, (0.0, 0.0), NO_SLIP);
    d.run(0.5, 0.4, 0.0, (0.0, 0.0), [1.0, 1.0, 1.0, 4.0]);
    d.run(2.0, 0.4, 0.0, (0.0, 0.0), NO_SLIP);
    d.run(0.5, 0.4, 0.0, (0.0, 0.0), [1.0, 0.0, 1.0, 1.0]);
    d.run(1.0, 0.4, 0.0, (0.0, 0.0), NO_SLIP);
    assert!((d.xyz().x - 2.4).abs() < 0.01, "{}", d.xyz());
    assert_eq!(d.o.counters().slip_events, 2);
    assert!(!d.o.slipping());
}

#[test]
fn o5_a_whole_side_spinning_is_caught_by_the_gyro() {
    // Both left wheels spin at twice the speed; the gyro says straight.
    let mut d = Drive::new(params());
    d.run(10.0, 0.4, 0.0, (0.0, 0.0), [2.0, 1.0, 2.0, 1.0]);
    let t = d.xyz();
    assert!((t.x - 4.0).abs() < 0.01, "{t}");
    let c = *d.o.counters();
    assert!(c.ambiguous_steps >= 990 && c.yaw_mismatches >= 990, "{c:?}");
    assert_eq!(c.wheel_slips, [1000, 0, 1000, 0]);
}

#[test]
fn o5_without_the_gyro_the_sides_are_checked_front_against_rear() {
    let mut o = Odometry::new(params());
    o.wheels(0, [0; 4]);
    // No IMU at all: front left spins.
    for k in 1..=100 {
        let c = (k * 10) as i32;
        o.wheels(k * 10 * MS, [3 * c, c, c, c]);
    }
    let x = o.pose().translation.vector.x;
    assert!((x - 2.0 * PI * 0.2).abs() < 1e-9, "{x}");
    assert_eq!(o.counters().wheel_slips, [100, 0, 0, 0]);
}

#[test]
fn o6_roll_and_pitch_converge_to_the_devices() {
    let mut d = Drive::new(params());
    let (roll, pitch) = (0.1, -0.05);
    // The body tilts while the gyro says nothing (a rate it missed):
    // after one time constant 63 % of the way, after eight all of it.
    d.run(1.0, 0.0, 0.0, (roll, pitch), NO_SLIP);
    let (r, p, y) = rot::to_rpy(&d.o.pose().rotation);
    assert!((r / roll - 0.632).abs() < 0.01, "{r}");
    assert!((p / pitch - 0.632).abs() < 0.01, "{p}");
    d.run(7.0, 0.0, 0.0, (roll, pitch), NO_SLIP);
    let (r, p, y2) = rot::to_rpy(&d.o.pose().rotation);
    assert!(
        (r - roll).abs() < 1e-4 && (p - pitch).abs() < 1e-4,
        "{r} {p}"
    );
    // Heading never follows the device's (which drifted 2.4 rad).
    assert!(y.abs() < 1e-12 && y2.abs() < 1e-12, "{y} {y2}");
}

#[test]
fn o6_the_first_sample_sets_roll_and_pitch_and_heading_is_zero() {
    let mut o = Odometry::new(params());
    let q = rot::from_rpy(0.2, -0.1, 2.0);
    o.imu(&ImuInput {
        time_ns: 5,
        gyro: [0.0; 3],
        orientation: wxyz(&q),
    });
    let (r, p, y) = rot::to_rpy(&o.pose().rotation);
    assert!((r - 0.2).abs() < 1e-12 && (p + 0.1).abs() < 1e-12 && y.abs() < 1e-12);
}

#[test]
fn o6_gyro_rotation_matching_the_device_does_not_lag() {
    // Rolling at 0.2 rad/s for 1 s, the device agreeing all along: the
    // integrated attitude and the device's stay together.
    let mut o = Odometry::new(params());
    for k in 0..=100u64 {
        let q = rot::from_rpy(0.002 * k as f64, 0.0, 0.0);
        o.imu(&ImuInput {
            time_ns: k * 10 * MS,
            gyro: [0.2, 0.0, 0.0],
            orientation: wxyz(&q),
        });
    }
    let (r, _, _) = rot::to_rpy(&o.pose().rotation);
    assert!((r - 0.2).abs() < 1e-9, "{r}");
}

#[test]
fn o7_bad_samples_do_not_panic_or_poison_the_pose() {
    let mut o = Odometry::new(params());
    let bad = [
        ImuInput {
            time_ns: 0,
            gyro: [f64::NAN, 0.0, 0.0],
            orientation: [f64::NAN; 4],
        },
        ImuInput {
            time_ns: 10 * MS,
            gyro: [0.0, 0.0, 1e9],
            orientation: [0.0; 4],
        },
        // Repeated time, then backwards.
        imu(10, 1.0),
        imu(5, 1.0),
        ImuInput {
            time_ns: 20 * MS,
            gyro: [f64::INFINITY; 3],
            orientation: [1e300, 1e300, 0.0, 0.0],
        },
        ImuInput {
            time_ns: 30 * MS,
            gyro: [0.0; 3],
            orientation: [-1.0, 0.0, 0.0, 0.0],
        },
        // A long gap.
        imu(u64::MAX / MS, 0.1),
    ];
    for s in &bad {
        o.imu(s);
    }
    o.wheels(u64::MAX, [0; 4]);
    o.wheels(0, [i32::MIN; 4]);
    o.wheels(0, [i32::MAX; 4]);
    let pose = o.pose();
    assert!(pose.translation.vector.iter().all(|v| v.is_finite()));
    assert!(pose.rotation.coords.iter().all(|v| v.is_finite()));
    let c = o.counters();
    assert_eq!(c.imu_rejected, 3, "{c:?}");
    assert!(c.imu_gaps >= 3, "{c:?}");
    let mut z = Odometry::new(OdometryParams {
        wheel_radius_m: f64::NAN,
        counts_per_rev: 0.0,
        ..params()
    });
    z.wheels(0, [0; 4]);
    assert_eq!(z.wheels(1, [1; 4]), 0.0);
    assert!(z.pose().translation.vector.iter().all(|v| v.is_finite()));
}

#[test]
fn o8_the_same_inputs_give_bit_identical_poses() {
    let run = || {
        let mut d = Drive::new(params());
        d.run(3.0, 0.4, 0.3, (0.05, -0.1), [1.0, 1.3, 1.0, 1.0]);
        d.run(3.0, -0.2, -0.1, (-0.02, 0.1), [1.0, 1.0, 0.2, 1.0]);
        let p = *d.o.pose();
        let v = p.translation.vector;
        let q = p.rotation.coords;
        (
            [v.x, v.y, v.z, q.x, q.y, q.z, q.w].map(f64::to_bits),
            *d.o.counters(),
        )
    };
    assert_eq!(run(), run());
}

#[test]
fn o10_the_pose_is_carried_on_to_the_frame_time_by_the_last_rates() {
    // Rolling at 0.2 rad/s, the last sample at 100 ms; driving 0.5 m/s, the
    // last wheel step at 96 ms.
    let mut o = Odometry::new(params());
    for k in 0..=10u64 {
        o.imu(&ImuInput {
            time_ns: k * 10 * MS,
            gyro: [0.2, 0.0, 0.0],
            orientation: wxyz(&rot::from_rpy(0.002 * k as f64, 0.0, 0.0)),
        });
    }
    let per_m = 1000.0 / (2.0 * PI * 0.2);
    o.wheels(86 * MS, [0; 4]);
    o.wheels(96 * MS, [(0.005 * per_m).round() as i32; 4]);
    let (x0, r0) = (o.pose().translation.x, rot::to_rpy(&o.pose().rotation).0);
    // 6 ms later: 1.2 mrad more roll, and 10 ms of travel after the wheels.
    let p = o.pose_at(106 * MS);
    let (r, _, _) = rot::to_rpy(&p.rotation);
    assert!((r - r0 - 0.2 * 0.006).abs() < 1e-9, "{}", r - r0);
    let step = (0.005 * per_m).round() / per_m;
    assert!(
        (p.translation.x - x0 - step).abs() < 1e-9,
        "{}",
        p.translation.x - x0
    );
    // The state itself is not moved, and a time before the samples adds
    // nothing.
    assert_eq!(o.pose_at(50 * MS), *o.pose());
    // Samples older than the limit are a late sensor: no guess.
    assert_eq!(o.pose_at(100 * MS + MAX_EXTRAPOLATION_NS + MS), *o.pose());
    // A rejected rate of turn is not carried on.
    o.imu(&ImuInput {
        time_ns: 110 * MS,
        gyro: [f64::NAN, 0.0, 0.0],
        orientation: wxyz(&rot::from_rpy(0.022, 0.0, 0.0)),
    });
    let q = o.pose().rotation;
    assert!(o.pose_at(115 * MS).rotation.angle_to(&q) < 1e-12);
}
