//! The mailboxes every task reads and writes: the whole data flow of one
//! minor frame. Created once at start-up; nothing in it grows afterwards.
//! The messages themselves are `speleo_messages`' types.

use speleo_hal::canopen::supervisor::{DrivesState, StopReasons};
use speleo_hal::xsens_config::ConfigState;
use speleo_hal::CanFrame;
use speleo_messages::{
    Cloud, Counters, ExplorationStatus, HealthReport, ImuSample, LidarCounters, OdomPose, PlanMsg,
    RawFrame, SlamPose, Timing, WheelCommand, RAW_ARENA_BYTES, RAW_ENTRIES,
};
use speleo_odometry::{OdometryCounters, PoseHistory};
use speleo_scheduler::mailbox::{Fifo, Latest, Ring};

/// Odometry poses kept for deskewing: 2.56 s at 100 Hz.
pub const ODOM_HISTORY_LEN: usize = 256;
/// How far past its newest pose the odometry history extrapolates, ns.
pub const ODOM_HISTORY_EXTRAPOLATION_NS: u64 = 5_000_000;

pub struct Bus {
    pub raw: RawFrame,
    pub imu: Ring<ImuSample, 32>,
    pub cloud: Latest<Cloud>,
    pub lidar: LidarCounters,
    pub drives: Latest<DrivesState>,
    /// Why the drive output holds the wheels at zero, every frame.
    pub drive_stop: Latest<StopReasons>,
    pub odom: Latest<OdomPose>,
    pub slam: Latest<SlamPose>,
    /// The odometry poses of the last frames, stamped with the frame time,
    /// for deskewing LiDAR revolutions. Written by the odometry task only.
    pub odom_history: PoseHistory,
    /// What the odometry counted (slip, glitches, bad IMU samples).
    pub odom_counters: OdometryCounters,
    /// The keyframes' clouds and poses for the maps: written by slam, read
    /// by maps. Empty until the mission sizes it.
    pub keyframe_clouds: speleo_mapping::KeyframeClouds,
    /// The multi-level surface maps: written by maps, read by the planner.
    /// One-cell maps until the mission sizes them.
    pub surface: speleo_mapping::SurfaceMaps,
    pub command: Latest<WheelCommand>,
    /// Written by the planner.
    pub plan: Latest<PlanMsg>,
    /// The exploration's state, written by the planner.
    pub exploration: ExplorationStatus,
    /// Frames to put on the CAN bus at the start of the next frame.
    pub can_tx: Fifo<CanFrame, 32>,
    /// Xbus messages for the IMU, sent at the start of the next frame.
    pub imu_tx: Fifo<heapless::Vec<u8, 256>, 4>,
    /// Where the IMU's configuration exchange is.
    pub imu_config: ConfigState,
    pub health: Latest<HealthReport>,
    pub counters: Counters,
    /// Set by health when the executive must switch to the safe schedule.
    pub safe_mode_request: bool,
    /// Set by health when nothing has been wrong for long enough to leave
    /// the safe schedule.
    pub recovery_ready: bool,
    pub timing: Timing,
}

impl Bus {
    pub fn new() -> Box<Bus> {
        Box::new(Bus {
            raw: RawFrame::with_capacity(RAW_ARENA_BYTES, RAW_ENTRIES),
            imu: Ring::new(),
            cloud: Latest::new(),
            lidar: LidarCounters::default(),
            drives: Latest::new(),
            drive_stop: Latest::new(),
            odom: Latest::new(),
            slam: Latest::new(),
            odom_history: PoseHistory::with_capacity(
                ODOM_HISTORY_LEN,
                ODOM_HISTORY_EXTRAPOLATION_NS,
            ),
            odom_counters: OdometryCounters::default(),
            keyframe_clouds: speleo_mapping::KeyframeClouds::new(0, 0),
            surface: speleo_mapping::SurfaceMaps::empty(),
            command: Latest::new(),
            plan: Latest::new(),
            exploration: ExplorationStatus::default(),
            can_tx: Fifo::new(),
            imu_tx: Fifo::new(),
            imu_config: ConfigState::GoingToConfig,
            health: Latest::new(),
            counters: Counters::default(),
            safe_mode_request: false,
            recovery_ready: false,
            timing: Timing::default(),
        })
    }
}
