//! The driver on plans over a map with a ledge: the safety monitor's
//! stops, the rims it reports, plans driven to their end, and the map
//! probe's reading of stray returns.

use speleo_control::{
    AccelLimiter, AccelLimits, Driver, FollowerParams, GroundProbe, MlsProbe, Path, Probe,
    PurePursuit, SafetyMonitor, SafetyParams, SkidSteer, StopReason,
};
use speleo_mapping::mls::{MlsMap, MlsParams};
use speleo_messages::{PlanMsg, SlamPose, WheelCommand};

/// Ground seen for x in [0, 5), y in [0, 4); nothing beyond (a drop
/// the LiDAR could not see into).
fn map_with_a_ledge() -> MlsMap {
    let mut map = MlsMap::new(MlsParams::default()).unwrap_or_else(|e| panic!("{e}"));
    let mut pts = Vec::new();
    for i in 0..100 {
        for j in 0..80 {
            pts.push([i as f64 * 0.05 + 0.025, j as f64 * 0.05 + 0.025, 0.0]);
        }
    }
    map.insert_points(&pts);
    map
}

fn driver() -> Driver {
    Driver::new(
        PurePursuit::new(
            FollowerParams {
                lookahead_m: 0.8,
                cruise_speed: 0.4,
                max_yaw_rate: 0.8,
                goal_tolerance_m: 0.2,
            },
            Path::new(),
            false,
        ),
        SkidSteer {
            wheel_radius_m: 0.19,
            track_width_m: 0.52,
            skid_factor: 1.0,
            max_wheel_speed: 5.0,
        },
        AccelLimiter::new(AccelLimits {
            max_accel: 0.5,
            max_decel: 1.0,
            max_yaw_accel: 2.0,
        }),
        SafetyMonitor::new(SafetyParams::default()),
    )
    .following_plans(FollowerParams {
        lookahead_m: 0.8,
        cruise_speed: 0.4,
        max_yaw_rate: 0.8,
        goal_tolerance_m: 0.2,
    })
}

/// Where a driven plan ended.
struct Ended {
    x: f64,
    yaw: f64,
    command: WheelCommand,
    /// Some command drove backward.
    reversed: bool,
}

/// Drive a unicycle with the driver's commands from (1, 2) heading +x
/// along a plan through `poses` until the driver reports it done.
fn drive(map: &MlsMap, t: &mut Driver, poses: impl Iterator<Item = [f32; 4]>) -> Ended {
    let mut plan = PlanMsg {
        query: 1,
        execute: true,
        optimal: true,
        ..PlanMsg::default()
    };
    for p in poses {
        let _ = plan.poses.push(p);
    }
    let (mut x, mut y, mut yaw) = (1.0, 2.0, 0.0f64);
    let mut reversed = false;
    for f in (1..3000).step_by(2) {
        let q = [(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()];
        let pose = SlamPose {
            position: [x, y, 0.17],
            orientation: q,
            keyframes: 1,
        };
        let c = t.step(f * 10_000_000, &pose, Some(&plan), map);
        if c.done {
            return Ended {
                x,
                yaw,
                command: c,
                reversed,
            };
        }
        reversed |= c.speed < -0.05;
        let dt = 0.02;
        yaw += c.yaw_rate * dt;
        x += c.speed * yaw.cos() * dt;
        y += c.speed * yaw.sin() * dt;
    }
    panic!("the traverse never ended at x = {x}");
}

#[test]
fn the_safety_monitor_stops_the_rover_before_it_leaves_the_map() {
    let map = map_with_a_ledge();
    let mut t = driver();
    // To (9, 2), past the ledge.
    let out = (0..=80).map(|k| [1.0 + 0.1 * k as f32, 2.0, 0.0, 0.0]);
    let Ended { x, command: c, .. } = drive(&map, &mut t, out);
    assert_eq!(c.stop, Some(StopReason::LeavingMap));
    assert_eq!((c.speed, c.yaw_rate), (0.0, 0.0));
    assert_eq!(c.plan, 1);
    // The wheels' front (half the body ahead of base_link) is still
    // over the ground that was seen.
    assert!(x + 0.5 < 5.0 && x > 3.5, "stopped at x = {x}");
    assert_eq!(t.counters.stops[StopReason::LeavingMap as usize - 1], 1);
    // Nothing was seen beyond: a gap, no rim.
    assert_eq!(c.rim, None);
}

#[test]
fn a_stop_before_a_drop_seen_says_where_the_rim_is_until_the_next_plan() {
    let mut map = map_with_a_ledge();
    // The floor 2 m under the ledge, seen beyond it.
    let floor: Vec<[f64; 3]> = (0..60)
        .flat_map(|i| (0..80).map(move |j| (i, j)))
        .map(|(i, j)| [5.025 + i as f64 * 0.05, j as f64 * 0.05 + 0.025, -2.0])
        .collect();
    map.insert_points(&floor);
    let mut t = driver();
    let out = (0..=80).map(|k| [1.0 + 0.1 * k as f32, 2.0, 0.0, 0.0]);
    let Ended { x, command: c, .. } = drive(&map, &mut t, out);
    assert_eq!(c.stop, Some(StopReason::LeavingMap));
    assert!(x + 0.5 < 5.0, "stopped at x = {x}");
    let rim = c.rim.unwrap_or_else(|| panic!("no rim: {c:?}"));
    assert!(
        rim[0] > 5.0 && rim[0] < 5.5 && (rim[1] - 2.0).abs() < 0.3,
        "{rim:?}"
    );
    // The next plan starts without it.
    let mut next = PlanMsg {
        query: 2,
        execute: true,
        optimal: true,
        ..PlanMsg::default()
    };
    let _ = next.poses.push([1.0, 2.0, 0.0, 0.0]);
    let _ = next.poses.push([2.0, 2.0, 0.0, 0.0]);
    let pose = SlamPose {
        position: [x, 2.0, 0.17],
        orientation: [1.0, 0.0, 0.0, 0.0],
        keyframes: 1,
    };
    let c = t.step(9001 * 10_000_000, &pose, Some(&next), &map);
    assert_eq!(c.rim, None);
}

#[test]
fn a_plan_on_seen_ground_is_driven_to_its_end() {
    let map = map_with_a_ledge();
    let mut t = driver();
    // Out along the ground, then backing up to x = 2.5.
    let out = (0..=20).map(|k| [1.0 + 0.1 * k as f32, 2.0, 0.0, 0.0]);
    let back = (1..=5).map(|k| [3.0 - 0.1 * k as f32, 2.0, 0.0, 0.0]);
    let e = drive(&map, &mut t, out.chain(back));
    assert_eq!(e.command.stop, None);
    assert!(e.reversed, "the last leg is driven backward");
    assert!((e.x - 2.5).abs() < 0.3, "ended at {}", e.x);
    assert!(e.yaw.abs() < 0.1, "it did not turn round: {}", e.yaw);
}

#[test]
fn one_return_from_below_does_not_block_the_body_but_two_or_one_from_above_do() {
    let probe_after = |points: &[[f64; 3]], sensor_z: f64| {
        let mut map = map_with_a_ledge();
        map.insert_points_seen_from(points, sensor_z);
        MlsProbe(&map).probe(2.02, 2.02, 0.0, 0.2)
    };
    assert_eq!(probe_after(&[], 0.5), Probe::Ground);
    let one = [[2.02, 2.02, 0.4]];
    assert_eq!(probe_after(&one, 0.0), Probe::Ground, "a stray return");
    assert_eq!(probe_after(&one, 0.6), Probe::Blocked, "seen from above");
    let two = [[2.02, 2.02, 0.4], [2.03, 2.03, 0.42]];
    assert_eq!(probe_after(&two, 0.0), Probe::Blocked, "two returns");
}
