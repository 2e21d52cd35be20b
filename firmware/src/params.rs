//! The components' parameters as the configuration gives them: the one
//! place where sections of `Config` become the parameters the tasks'
//! components are built with.

use speleo_control::{
    AccelLimiter, AccelLimits, Driver, FollowerParams, Path, PurePursuit, SafetyMonitor,
    SafetyParams, SkidSteer,
};
use speleo_hal::canopen::supervisor::SupervisorParams;
use speleo_hal::cia402;
use speleo_hal::hdl32e::calib::CalibError;
use speleo_odometry::OdometryParams;

use crate::config::Config;

pub fn lidar_calibration(cfg: &Config) -> Result<speleo_hal::hdl32e::Calibration, CalibError> {
    use speleo_hal::hdl32e::Calibration;
    let l = &cfg.lidar;
    Ok(if l.calibration.is_empty() {
        Calibration::nominal()
    } else {
        Calibration::load(std::path::Path::new(&l.calibration))?
    })
}

/// Where the LiDAR's downward rings meet the ground the rover stands on,
/// within `maps.unseen_ground_reach_m` (none at 0).
pub fn expected_ground(
    cfg: &Config,
) -> Result<Option<speleo_mapping::mls::ExpectedGround>, CalibError> {
    let reach = cfg.maps.unseen_ground_reach_m;
    if reach <= 0.0 {
        return Ok(None);
    }
    let cal = lidar_calibration(cfg)?;
    let elevations = cal.lasers.map(|l| l.vert_deg);
    // One ray a degree: 2.8 cm apart at 1.6 m, under the 10 cm cells.
    Ok(Some(speleo_mapping::mls::ExpectedGround::new(
        &mount_pose(cfg).to_isometry(),
        &elevations,
        -base_height_m(cfg),
        reach,
        360,
    )))
}

/// The health task's limits from `[health]`.
pub fn health(cfg: &Config) -> speleo_health::HealthParams {
    let h = &cfg.health;
    let ms = |v: u32| v as u64 * 1_000_000;
    // Checks run every 100 ms.
    let checks = h.wheel_disagreement_ms.div_ceil(100).max(1);
    speleo_health::HealthParams {
        imu_limit_ns: ms(h.imu_timeout_ms),
        drive_limit_ns: ms(h.drive_heartbeat_timeout_ms),
        lidar_limit_ns: ms(h.lidar_timeout_ms),
        grace_ns: ms(h.startup_grace_ms),
        safe_on_stale: h.safe_mode_on_stale,
        wheel_checks: checks,
        storm_overruns: h.overrun_storm_per_s as u64,
        clock_jump_ns: ms(h.clock_jump_ms),
        recover_after_ns: ms(h.recover_after_ms),
    }
}

/// The chassis' reference height over the ground: the hubs, less the
/// wheels' give.
pub fn base_height_m(cfg: &Config) -> f64 {
    0.9 * cfg.rover.wheel_radius_m
}

/// The path follower over `[control] path`.
pub fn follower(cfg: &Config) -> PurePursuit {
    let mut path = Path::new();
    for p in &cfg.control.path {
        let _ = path.push(*p);
    }
    PurePursuit::new(follower_params(cfg), path, cfg.control.looped)
}

/// The internal simulator: the simulated rover's build, the control
/// task's follower and limits, `[simulator]`'s world and judgement.
pub fn simulator(cfg: &Config) -> speleo_simulator::SimulatorParams {
    let s = &cfg.simulator.params;
    speleo_simulator::SimulatorParams {
        physics: cfg.sim.rover.clone(),
        follower: follower_params(cfg),
        limits: accel_limits(cfg),
        skid: skid_steer(cfg),
        // The rover's own safety monitor stops it at its tilt limit: a
        // plan that tilts it past that fails on board as surely as one
        // that turns it over (in the garage, plans the simulation passed
        // at 32 degrees, a wheel down a ramp's side, stopped the rover
        // there).
        tip_over_deg: s.tip_over_deg.min(cfg.control.max_tilt_deg),
        base_height_m: base_height_m(cfg),
        ..s.clone()
    }
}

/// Pure pursuit's lookahead, speed and turn rate from `[control]`.
pub fn follower_params(cfg: &Config) -> FollowerParams {
    FollowerParams {
        lookahead_m: cfg.control.lookahead_m,
        cruise_speed: cfg.control.cruise_speed,
        max_yaw_rate: cfg.control.max_yaw_rate,
        goal_tolerance_m: 0.2,
    }
}

/// The LiDAR mount from the configuration: base <- sensor.
pub fn mount_pose(cfg: &Config) -> speleo_slam::lie::Pose {
    let [r, p, y] = cfg.lidar.mount_rpy_deg.map(f64::to_radians);
    let q = nalgebra::UnitQuaternion::from_euler_angles(r, p, y);
    speleo_slam::lie::Pose::new(
        *q.to_rotation_matrix().matrix(),
        nalgebra::Vector3::from(cfg.lidar.mount_xyz),
    )
}

/// Wheel odometry's geometry from `[rover]`.
pub fn odometry(cfg: &Config) -> OdometryParams {
    let r = &cfg.rover;
    OdometryParams {
        wheel_radius_m: r.wheel_radius_m,
        counts_per_rev: cia402::COUNTS_PER_REV as f64,
        max_step_m: 1.0,
        track_width_m: r.track_width_m,
        skid_factor: r.skid_factor,
        ..OdometryParams::default()
    }
}

/// The skid-steer geometry and wheel speed limit from `[rover]`.
pub fn skid_steer(cfg: &Config) -> SkidSteer {
    let r = &cfg.rover;
    SkidSteer {
        wheel_radius_m: r.wheel_radius_m,
        track_width_m: r.track_width_m,
        skid_factor: r.skid_factor,
        max_wheel_speed: r.max_wheel_speed,
    }
}

/// The acceleration limits from `[control]`.
pub fn accel_limits(cfg: &Config) -> AccelLimits {
    let c = &cfg.control;
    AccelLimits {
        max_accel: c.max_accel,
        max_decel: c.max_decel,
        max_yaw_accel: c.max_yaw_accel,
    }
}

/// The driver: the follower, the wheels' limits and the safety monitor;
/// following the planner's plans when `following_plans`.
pub fn driver(cfg: &Config, following_plans: bool) -> Driver {
    let c = &cfg.control;
    let driver = Driver::new(
        follower(cfg),
        skid_steer(cfg),
        AccelLimiter::new(accel_limits(cfg)),
        SafetyMonitor::new(SafetyParams {
            max_tilt_deg: c.max_tilt_deg,
            stuck_after_s: c.stuck_after_s,
            max_cross_track_m: c.max_cross_track_m,
            // The step as the decimal written, not its f32.
            max_step_m: speleo_params::decimal(cfg.planner.nav.trav.max_step_m),
            max_slope_deg: cfg.planner.nav.trav.max_slope_deg,
            base_height_m: base_height_m(cfg),
            front_m: 0.5 * cfg.planner.nav.surface.body_length_m,
            half_track_m: 0.5 * cfg.rover.track_width_m,
            ..SafetyParams::default()
        }),
    );
    if following_plans {
        driver.following_plans(follower_params(cfg))
    } else {
        driver
    }
}

/// The drive supervisor's timeouts and speed limit from `[health]`,
/// `[control]` and `[rover]`.
pub fn supervisor(cfg: &Config) -> SupervisorParams {
    SupervisorParams {
        heartbeat_timeout_ns: cfg.health.drive_heartbeat_timeout_ms as u64 * 1_000_000,
        command_timeout_ns: cfg.control.command_timeout_ms as u64 * 1_000_000,
        retry_ns: 200_000_000,
        boot_grace_ns: cfg.health.startup_grace_ms as u64 * 1_000_000,
        max_velocity: (cfg.rover.max_wheel_speed * 1000.0).round() as i32,
        fault_reset_ns: cfg.health.drive_fault_reset_ms as u64 * 1_000_000,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_internal_simulation_fails_a_plan_where_the_safety_monitor_would_stop_the_rover() {
        let mut cfg = Config::default();
        cfg.control.max_tilt_deg = 30.0;
        cfg.simulator.params.tip_over_deg = 45.0;
        assert_eq!(simulator(&cfg).tip_over_deg, 30.0);
        // A lower tip-over angle of its own still counts.
        cfg.simulator.params.tip_over_deg = 25.0;
        assert_eq!(simulator(&cfg).tip_over_deg, 25.0);
    }
}
