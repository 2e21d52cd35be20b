//! The exploration around queries: energy, retrace directions, slides,
//! rims, tilt stalls.

use super::*;
use crate::exploration::recovery::TILT_STALLS_TO_STRAND;
use crate::exploration::MAX_RIMS;
use speleo_control::StopReason;
use speleo_exploration::{ExplorerPhase, ReturnReason};
use speleo_messages::DriveFeedback;

fn at(rig: &mut Rig, p: [f64; 3]) {
    rig.slam.publish(
        0,
        SlamPose {
            position: p,
            orientation: [1.0, 0.0, 0.0, 0.0],
            keyframes: 1,
        },
    );
}

fn exploration() -> Exploration {
    Exploration::new(
        ExplorerParams::default(),
        CandidateParams::default(),
        None,
        1.0,
    )
}

#[test]
fn the_drives_feedback_is_metered_and_the_budget_turns_the_rover_home() {
    use speleo_hal::canopen::supervisor::DrivesState;
    // Driving along x at 0.4 m/s, every wheel at 2 rad/s under 3 N m
    // (torque actual 200 of 1000): 45 W + 4 x (6 W / 0.7 + 0.54 W).
    let run = |torque: Option<i16>, budget_wh: f64| {
        let mut e = Exploration::new(
            ExplorerParams {
                energy_budget_wh: budget_wh,
                ..ExplorerParams::default()
            },
            CandidateParams::default(),
            None,
            1.0,
        );
        let mut rig = Rig::new();
        let mut drives = DrivesState::default();
        for n in drives.nodes.iter_mut() {
            n.velocity = 2000;
            n.torque = torque;
        }
        let mut turned_at = None;
        for k in 0..=10_000u64 {
            let now = k * 10_000_000;
            rig.drives.publish(now, DriveFeedback::from(&drives));
            at(&mut rig, [k as f64 * 0.004, 0.0, 0.0]);
            rig.observe(&mut e, now);
            if turned_at.is_none() && e.phase() == ExplorerPhase::Returning(ReturnReason::Energy) {
                turned_at = Some(now as f64 * 1e-9);
            }
        }
        (e.energy.used_wh(), e.energy.unmeasured_s(), turned_at)
    };
    let watts = 45.0 + 4.0 * (6.0 / 0.7 + 0.06 * 9.0);
    let (wh, unmeasured, turned) = run(Some(200), 0.0);
    assert!((wh - watts * 100.0 / 3600.0).abs() < 1e-3, "{wh} Wh");
    assert_eq!((unmeasured, turned), (0.0, None));
    // A 5 Wh budget: home is as far as the rover has come, so it turns
    // at 2 Wh (2 + 1.5 x 2 = 5), 88 s out.
    let (_, _, turned) = run(Some(200), 5.0);
    let t = turned.unwrap_or_else(|| panic!("never turned home"));
    let expected = 2.0 * 3600.0 / watts;
    assert!(
        (t - expected).abs() < 1.0,
        "turned at {t} s, not {expected}"
    );
    // Drives that map no torque: the base alone, and the time counted.
    let (wh, unmeasured, _) = run(None, 0.0);
    assert!((wh - 45.0 * 100.0 / 3600.0).abs() < 1e-3, "{wh} Wh");
    assert!((unmeasured - 100.0).abs() < 0.02, "{unmeasured} s");
}

#[test]
fn a_retrace_goes_back_the_way_the_rover_came_and_on_the_way_home_toward_home() {
    let mut e = exploration();
    let mut rig = Rig::new();
    // Out to 20 m, and back to 10 m.
    for k in 0..=20 {
        e.explorer.observe(k as f64, [k as f64, 0.0, 0.0]);
    }
    for k in (10..20).rev() {
        e.explorer.observe(40.0 - k as f64, [k as f64, 0.2, 0.0]);
    }
    at(&mut rig, [10.0, 0.1, 0.0]);
    let end = |rig: &Rig| rig.plan.get().and_then(|p| p.value.poses.last().copied());
    // Exploring: back where it just came from.
    rig.retrace(&mut e, 1, 1, 5.0);
    let out = end(&rig).unwrap_or_else(|| panic!("no retrace"));
    assert!(out[0] > 14.0, "{out:?}");
    // Going home: along the track from its first pass, toward home.
    for _ in 0..3 {
        e.explorer.query_result(false);
    }
    assert!(matches!(e.phase(), ExplorerPhase::Returning(_)));
    rig.retrace(&mut e, 2, 2, 5.0);
    let home = end(&rig).unwrap_or_else(|| panic!("no retrace"));
    assert!(home[0] < 6.0, "{home:?}");
}

#[test]
fn a_rover_stopped_at_the_maps_edge_retraces_without_turning_round() {
    use speleo_messages::WheelCommand;
    let heading_after_at = |stop: StopReason, yaw: f64, at: [f64; 3]| {
        let mut e = exploration();
        let mut rig = Rig::new();
        // Out along x to 10 m.
        for k in 0..=10 {
            e.explorer.observe(k as f64, [k as f64, 0.0, 0.0]);
        }
        e.homed = true;
        rig.slam.publish(
            0,
            SlamPose {
                position: at,
                orientation: [(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()],
                keyframes: 1,
            },
        );
        rig.command.publish(
            0,
            WheelCommand {
                done: true,
                stop: Some(stop),
                ..Default::default()
            },
        );
        assert!(!rig.ready(&mut e, 0), "settling");
        rig.retrace(&mut e, 1, 1, 4.0);
        let poses = rig.plan.get().map(|p| p.value.poses.clone());
        let poses = poses.unwrap_or_else(|| panic!("no retrace"));
        assert!(poses.iter().all(|q| q[0] <= 10.0 + 1e-3), "{poses:?}");
        poses[1][3]
    };
    let heading_after = |stop: StopReason, yaw: f64| heading_after_at(stop, yaw, [10.0, 0.0, 0.0]);
    // Blocked: back along the track, facing it (turning round first).
    assert!(heading_after(StopReason::Blocked, 0.0).abs() > 3.0);
    // At the map's edge: backing along it, facing the way it came.
    assert!(heading_after(StopReason::LeavingMap, 0.0).abs() < 0.1);
    // Stopped there backing up (facing back along the track): driven
    // forward, facing the way it faces still.
    let back = heading_after(StopReason::LeavingMap, std::f64::consts::PI);
    assert!(back.abs() > 3.0, "{back}");
    // The pose jumped 0.7 m sideways (a loop closure) after the stop:
    // the leg to the track's end point runs 60° right of the yaw, but
    // the track runs back the other way: backing along it still.
    let jumped = heading_after_at(StopReason::LeavingMap, 0.0, [9.6, 0.7, 0.0]);
    assert!(jumped.abs() < 0.1, "{jumped}");
}

#[test]
fn a_retrace_does_not_drive_back_up_to_a_point_the_rover_slid_back_from() {
    let mut e = exploration();
    let mut rig = Rig::new();
    // Up a slope along x to 6 m, then slid back to 5.2 m: the track's
    // last point near the rover is 0.8 m ahead of it.
    for k in 0..=6 {
        e.explorer.observe(k as f64, [k as f64, 0.0, 0.0]);
    }
    at(&mut rig, [5.2, 0.0, 0.0]);
    rig.retrace(&mut e, 1, 1, 4.0);
    let poses = rig.plan.get().map(|p| p.value.poses.clone());
    let poses = poses.unwrap_or_else(|| panic!("no retrace"));
    assert!(poses.len() >= 3, "{poses:?}");
    // From where it stands straight back down, never up to x = 6.
    assert!(poses.iter().all(|q| q[0] <= 5.2 + 1e-3), "{poses:?}");
    assert!(poses[1][0] > 4.5 && poses[1][0] < 5.2, "{poses:?}");
}

#[test]
fn tilt_stops_in_one_place_strand_the_rover_and_moving_on_resets_the_count() {
    let mut e = exploration();
    let mut rig = Rig::new();
    let tilt = Some(StopReason::Tilt);
    // Tilt stops that each got somewhere, or other stops between
    // them, never strand it.
    for k in 0..2 * TILT_STALLS_TO_STRAND {
        at(&mut rig, [k as f64, 0.0, 0.0]);
        e.count_tilt_stall(tilt, &rig.input(0));
    }
    at(&mut rig, [50.0, 0.0, 0.0]);
    for _ in 0..TILT_STALLS_TO_STRAND - 1 {
        e.count_tilt_stall(tilt, &rig.input(0));
    }
    e.count_tilt_stall(None, &rig.input(0));
    e.count_tilt_stall(tilt, &rig.input(0));
    assert_eq!(e.explorer.phase(), ExplorerPhase::Exploring);
    // Stop after stop where it stood: stranded, the mission over.
    for _ in 0..TILT_STALLS_TO_STRAND {
        at(&mut rig, [50.02, 0.01, 0.0]);
        e.count_tilt_stall(tilt, &rig.input(0));
    }
    assert_eq!(e.explorer.phase(), ExplorerPhase::Stranded);
    assert!(!e.retrace_due());
}

#[test]
fn a_stop_pitched_up_a_steep_slope_is_kept_as_a_slide_once() {
    let mut e = exploration();
    e.set_base_height(0.15);
    let mut rig = Rig::new();
    let pitched = |rig: &mut Rig, p: [f64; 3], deg: f64| {
        let h = deg.to_radians() / 2.0;
        rig.slam.publish(
            0,
            SlamPose {
                position: p,
                orientation: [h.cos(), 0.0, h.sin(), 0.0],
                keyframes: 1,
            },
        );
    };
    let off_path = Some(StopReason::OffPath);
    // Off the path on a garage ramp (14 deg), or tilted past the
    // limit: no slide.
    pitched(&mut rig, [1.0, 0.0, 0.5], -14.0);
    e.note_slide(off_path, &rig.input(0));
    pitched(&mut rig, [1.0, 0.0, 0.5], -21.0);
    e.note_slide(Some(StopReason::Tilt), &rig.input(0));
    assert!(e.slides.is_empty());
    // Slid off the path nose up at 21 deg: kept, on the ground.
    pitched(&mut rig, [-6.0, -1.0, 1.65], -21.0);
    e.note_slide(off_path, &rig.input(0));
    assert_eq!(e.slides.len(), 1);
    let s = *e.slides.front().expect("a slide");
    assert!((s[2] - 1.5).abs() < 1e-9, "{s:?}");
    // Stalled again beside it: the same place.
    pitched(&mut rig, [-6.2, -0.9, 1.7], 20.0);
    e.note_slide(Some(StopReason::NoProgress), &rig.input(0));
    assert_eq!((e.slides.len(), e.counters.slides), (1, 1));
    // Going home, a slide bars nothing (home may be up a slope).
    for _ in 0..3 {
        e.explorer.query_result(false);
    }
    assert!(matches!(e.phase(), ExplorerPhase::Returning(_)));
    pitched(&mut rig, [30.0, 0.0, -3.0], -22.0);
    e.note_slide(Some(StopReason::Stuck), &rig.input(0));
    assert_eq!(e.slides.len(), 1);
}

#[test]
fn a_stop_at_a_rim_is_kept_once_on_the_rovers_ground() {
    use speleo_messages::WheelCommand;
    let mut e = exploration();
    e.set_base_height(0.2);
    let mut rig = Rig::new();
    at(&mut rig, [3.0, 1.0, 9.2]);
    let stop = |rig: &mut Rig, rim: Option<[f64; 2]>| {
        rig.command.publish(
            0,
            WheelCommand {
                done: true,
                stop: Some(StopReason::LeavingMap),
                rim,
                ..Default::default()
            },
        );
    };
    // Ground unseen ahead: no rim.
    stop(&mut rig, None);
    e.note_rim(&rig.input(0));
    assert!(e.rims.is_empty());
    stop(&mut rig, Some([3.6, 1.9]));
    e.note_rim(&rig.input(0));
    stop(&mut rig, Some([3.7, 1.95]));
    e.note_rim(&rig.input(0));
    assert_eq!((e.rims.len(), e.counters.rims), (1, 1));
    let r = *e.rims.front().expect("a rim");
    assert!(
        (r[0] - 3.6).abs() < 1e-9 && (r[2] - 9.0).abs() < 1e-9,
        "{r:?}"
    );
    // Past the limit, the oldest goes.
    for k in 0..MAX_RIMS {
        stop(&mut rig, Some([10.0 + k as f64, 0.0]));
        e.note_rim(&rig.input(0));
    }
    assert_eq!(e.rims.len(), MAX_RIMS);
    assert!(e.rims.front().is_some_and(|r| r[0] == 10.0));
}
