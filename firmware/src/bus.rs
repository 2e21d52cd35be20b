//! The mailboxes every task reads and writes: the whole data flow of one
//! minor frame. Created once at start-up; nothing in it grows afterwards.

use speleo_hal::canopen::supervisor::{DrivesState, StopReasons};
use speleo_hal::xbus::XbusCounters;
use speleo_hal::xsens_config::ConfigState;
use speleo_hal::{CanFrame, Device, InputSink};
use speleo_odometry::{OdometryCounters, PoseHistory};
use speleo_scheduler::mailbox::{Fifo, Latest, Ring};
use speleo_scheduler::Mode;

/// One decoded IMU sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImuSample {
    pub packet_counter: u16,
    pub sample_time_fine: u32,
    /// w, x, y, z
    pub orientation: [f64; 4],
    pub acceleration: [f64; 3],
    pub rate_of_turn: [f64; 3],
    pub status_word: u32,
}

/// One LiDAR revolution. Its storage is allocated at start-up and recycled.
#[derive(Clone, Debug, Default)]
pub struct Cloud {
    pub index: u64,
    /// Sensor time of the first firing, microseconds past the hour (plus
    /// whole hours since start).
    pub start_us: f64,
    /// When the packet that completed it had fired its last block, same
    /// clock (the cloud's stamp is that packet's arrival).
    pub end_us: f64,
    /// Point times are seconds after the first firing.
    pub points: Vec<speleo_hal::hdl32e::Point>,
}

/// The SLAM estimate of the rover's pose in the map frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlamPose {
    pub position: [f64; 3],
    /// (w, x, y, z).
    pub orientation: [f64; 4],
    pub keyframes: u32,
}

/// What the LiDAR driver counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LidarCounters {
    pub packets: u64,
    pub bad_length: u64,
    pub bad_flag: u64,
    pub bad_azimuth: u64,
    pub bad_timestamp: u64,
    pub lost_packets: u64,
    pub out_of_order: u64,
    pub resyncs: u64,
    pub gaps: u64,
    pub dropped_points: u64,
    pub frames: u64,
    /// Frames not published because every buffer was in use.
    pub dropped_frames: u64,
    pub position_packets: u64,
    pub bad_position_packets: u64,
    /// Sensor time of the latest position packet, us past the hour.
    pub position_time_us: u32,
}

/// Odometry pose of base_link in the odom frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OdomPose {
    pub position: [f64; 3],
    /// w, x, y, z
    pub orientation: [f64; 4],
    pub distance_m: f64,
}

/// The path follower's command.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelCommand {
    pub speed: f64,
    pub yaw_rate: f64,
    /// rad/s: front left, front right, rear left, rear right.
    pub wheel_speeds: [f64; 4],
    pub segment: u32,
    pub done: bool,
    /// The plan being followed (its query number; 0: the configured path).
    pub plan: u64,
    /// Why the safety monitor stopped the rover on this plan
    /// (`speleo_control::StopReason` code; 0: it did not).
    pub stop: u8,
    /// Where that stop's probe saw a drop ahead (a `LeavingMap` stop at a
    /// rim, x and y in the map frame).
    pub rim: Option<[f64; 2]>,
}

/// Poses a published plan holds at most.
pub const PLAN_POSES: usize = 512;

/// The planner's latest plan: its states' ground positions and headings
/// in the map frame, start first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlanMsg {
    /// Query number (1 for the first).
    pub query: u64,
    /// Travel time, ms.
    pub cost_ms: u32,
    /// Proven bound on cost over the optimum (1: optimal).
    pub eps: f32,
    pub optimal: bool,
    /// The query is over and this plan is to be driven (exploration);
    /// earlier plans of a query only show its progress.
    pub execute: bool,
    /// x, y, z, yaw.
    pub poses: heapless::Vec<[f32; 4], PLAN_POSES>,
}

/// Where the exploration is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExplorationPhase {
    /// Not exploring (following a route).
    #[default]
    Off,
    Exploring,
    Returning,
    /// Home: the mission is over.
    Finished,
    /// Over away from home: the rover cannot move.
    Stranded,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExplorationStatus {
    pub phase: ExplorationPhase,
    /// The goal being driven to, when there is one.
    pub goal: Option<[f64; 3]>,
}

/// What the health task concluded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HealthReport {
    pub stale_mask: u32,
    pub drive_faults: u8,
    /// `tasks::health::finding` bits.
    pub findings: u16,
    pub safe_mode: bool,
}

/// The executive's own figures, mirrored between frames for health.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Timing {
    /// Task runs over budget so far.
    pub overruns: u64,
    /// Frames the clock skipped so far.
    pub slipped_frames: u64,
    /// The executive applies its overrun policies (real time, or a budget
    /// test on virtual time).
    pub enforcing: bool,
}

/// Counters every driver keeps, reported by health.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    pub imu: XbusCounters,
    pub imu_bad_items: u64,
    pub imu_other_messages: u64,
    pub can_frames: u64,
    pub can_malformed: u64,
    pub can_unmapped: u64,
    pub can_bad_length: u64,
    pub raw_dropped: u64,
    pub can_tx_dropped: u64,
    pub hal_errors: u64,
    /// Errors of the CAN controller (bus-off), sending or receiving.
    pub can_errors: u64,
    pub imu_samples_lost: u64,
}

/// One raw input of this frame, stored in [`RawFrame`]'s arena.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RawEntry {
    pub device: Device,
    pub receive_time_ns: u64,
    start: u32,
    len: u32,
}

/// The raw inputs received in the current frame: bytes in one arena sized at
/// start-up. Inputs that do not fit are dropped and counted.
#[derive(Debug)]
pub struct RawFrame {
    bytes: Vec<u8>,
    entries: Vec<RawEntry>,
    pub dropped: u64,
}

impl RawFrame {
    pub fn with_capacity(bytes: usize, entries: usize) -> Self {
        RawFrame {
            bytes: Vec::with_capacity(bytes),
            entries: Vec::with_capacity(entries),
            dropped: 0,
        }
    }

    pub fn clear(&mut self) {
        self.bytes.clear();
        self.entries.clear();
    }

    pub fn entries(&self) -> &[RawEntry] {
        &self.entries
    }

    pub fn bytes_of(&self, e: &RawEntry) -> &[u8] {
        &self.bytes[e.start as usize..(e.start + e.len) as usize]
    }

    /// Entries of one device with their bytes, in arrival order.
    pub fn of(&self, device: Device) -> impl Iterator<Item = (&RawEntry, &[u8])> {
        self.entries
            .iter()
            .filter(move |e| e.device == device)
            .map(|e| (e, self.bytes_of(e)))
    }
}

impl InputSink for RawFrame {
    fn input(&mut self, device: Device, receive_time_ns: u64, bytes: &[u8]) {
        // Never grow: the capacities were fixed at start-up.
        if self.entries.len() == self.entries.capacity()
            || self.bytes.len() + bytes.len() > self.bytes.capacity()
        {
            self.dropped += 1;
            return;
        }
        self.entries.push(RawEntry {
            device,
            receive_time_ns,
            start: self.bytes.len() as u32,
            len: bytes.len() as u32,
        });
        self.bytes.extend_from_slice(bytes);
    }
}

/// Arena sizes: a frame of HDL-32E traffic is ~18 packets of 1206 bytes.
pub const RAW_ARENA_BYTES: usize = 256 * 1024;
pub const RAW_ENTRIES: usize = 2048;

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
    pub keyframe_clouds: crate::keyframe_clouds::KeyframeClouds,
    /// The multi-level surface maps: written by maps, read by the planner.
    /// One-cell maps until the mission sizes them.
    pub surface: crate::surface_maps::SurfaceMaps,
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
    /// The executive's mode, mirrored for the recorder and health.
    pub mode: Mode,
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
            keyframe_clouds: crate::keyframe_clouds::KeyframeClouds::new(0, 0),
            surface: crate::surface_maps::SurfaceMaps::empty(),
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
            mode: Mode::Nominal,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_frame_never_grows() {
        let mut r = RawFrame::with_capacity(10, 2);
        r.input(Device::Imu, 1, &[1, 2, 3]);
        r.input(Device::Can, 2, &[4; 8]); // bytes full
        r.input(Device::Can, 3, &[5; 7]);
        r.input(Device::Can, 4, &[]); // entries full
        assert_eq!(r.entries().len(), 2);
        assert_eq!(r.dropped, 2);
        assert_eq!(
            r.of(Device::Imu).next().map(|(_, b)| b),
            Some(&[1u8, 2, 3][..])
        );
    }
}
