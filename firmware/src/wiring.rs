//! Who writes and who reads each of the bus's mailboxes: the rover's data
//! flow in one table, in the schedule's task order. The executive's own
//! row is the mission loop between frames. `firmware/tests/wiring.rs`
//! checks the table against the tasks' code.

/// One task's side of the wiring: the bus fields it writes (and may read
/// too) and those it only reads.
#[derive(Clone, Copy, Debug)]
pub struct Wiring {
    /// The task's name in the schedule table ("executive": the mission loop).
    pub task: &'static str,
    /// The task's source files under `firmware/src/tasks/`.
    pub files: &'static [&'static str],
    pub writes: &'static [&'static str],
    pub reads: &'static [&'static str],
}

/// The wiring of every task, then the executive's.
pub const WIRING: [Wiring; 13] = [
    Wiring {
        task: "io",
        files: &["io.rs"],
        writes: &["raw", "counters"],
        reads: &["can_tx", "imu_tx"],
    },
    Wiring {
        task: "lidar_driver",
        files: &["lidar_driver.rs"],
        writes: &["cloud", "lidar"],
        reads: &["raw"],
    },
    Wiring {
        task: "imu_driver",
        files: &["imu_driver.rs"],
        writes: &["imu", "imu_tx", "imu_config", "counters"],
        reads: &["raw"],
    },
    Wiring {
        task: "drive_driver",
        files: &["drive_driver.rs"],
        writes: &["drives", "counters"],
        reads: &["raw"],
    },
    Wiring {
        task: "odometry",
        files: &["odometry.rs"],
        writes: &["odom", "odom_history", "odom_counters", "counters"],
        reads: &["imu", "drives"],
    },
    Wiring {
        task: "slam",
        files: &["slam.rs"],
        writes: &["slam", "keyframe_clouds"],
        reads: &["cloud", "odom", "odom_history"],
    },
    Wiring {
        task: "maps",
        files: &["maps.rs"],
        writes: &["surface"],
        reads: &["keyframe_clouds"],
    },
    Wiring {
        task: "planner",
        files: &["planner.rs"],
        writes: &["plan", "exploration"],
        reads: &["slam", "surface", "command", "drives", "keyframe_clouds"],
    },
    Wiring {
        task: "control",
        files: &["control.rs"],
        writes: &["command"],
        reads: &["plan", "slam", "surface"],
    },
    Wiring {
        task: "drive_output",
        files: &["drive_output.rs"],
        writes: &["can_tx", "drive_stop"],
        reads: &["command", "drives"],
    },
    Wiring {
        task: "health",
        files: &["health.rs"],
        writes: &["health", "safe_mode_request", "recovery_ready"],
        reads: &[
            "drives",
            "drive_stop",
            "imu",
            "lidar",
            "odom_counters",
            "counters",
            "timing",
        ],
    },
    Wiring {
        task: "recorder",
        files: &["recorder.rs"],
        writes: &[],
        reads: &[
            "raw",
            "imu",
            "cloud",
            "drives",
            "drive_stop",
            "odom",
            "slam",
            "plan",
            "command",
            "can_tx",
            "imu_tx",
            "imu_config",
            "health",
            "counters",
        ],
    },
    Wiring {
        task: "executive",
        files: &[],
        writes: &["timing", "recovery_ready"],
        reads: &["safe_mode_request"],
    },
];
