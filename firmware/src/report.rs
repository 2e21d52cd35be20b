//! The `--report OUT.json` contract. Later work adds keys; the ones here stay.

use serde::Serialize;

use crate::mission::{MissionResult, TaskFigures};
use crate::record::messages::mode_name;

#[derive(Serialize)]
pub struct Report<'a> {
    pub mode: &'a str,
    pub frames: u64,
    pub sim_time_s: f64,
    pub wall_time_s: f64,
    /// xxh3-64 over every recorded output message, in order, as 16 hex digits.
    pub output_hash: String,
    pub input_hash: String,
    pub scheduler: SchedulerReport<'a>,
    pub recorder: RecorderReport,
    pub counters: serde_json::Value,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub replay: Option<ReplayReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slam: Option<&'a crate::slam_figures::SlamFigures>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub maps: Option<&'a crate::maps_output::MapsFigures>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planner: Option<&'a crate::planner_figures::PlannerFigures>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exploration: Option<&'a crate::exploration_figures::ExplorationFigures>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub internal_sim: Option<&'a crate::exploration_figures::InternalSimFigures>,
    pub faults: &'a crate::faults::log::FaultFigures,
    /// A simulated exploration's verdict, each part of success named.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub success: Option<&'a speleo_campaign::success::Success>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory: Option<crate::mission::MemoryFigures>,
    /// What the live view sent and dropped (with `--live`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub live: Option<crate::record::live::LiveCounters>,
    /// Timing in real time (`run`): frame start lateness, latencies, and
    /// what real-time setup was granted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub realtime: Option<&'a crate::realtime_figures::RealtimeFigures>,
    /// Where the rover believed it was at the end.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub end: Option<crate::mission::EndPose>,
}

#[derive(Serialize)]
pub struct SchedulerReport<'a> {
    pub minor_frame_us: u32,
    pub slips: u64,
    /// Heap allocations by the executive and its periodic tasks after start-up.
    pub allocations_after_init: u64,
    /// Allocations of tasks that run within a memory budget (SLAM's solver).
    pub budgeted_allocations: u64,
    /// Allocations of logging and progress display between frames.
    pub housekeeping_allocations: u64,
    pub mode_at_end: &'a str,
    pub safe_mode_cause: Option<&'a str>,
    pub suppressed_overrun_events: u64,
    pub tasks: &'a [TaskFigures],
}

#[derive(Serialize)]
pub struct RecorderReport {
    pub outputs: u64,
    pub written: u64,
    pub dropped_no_buffer: u64,
    pub too_large: u64,
    pub writer_failed: bool,
}

#[derive(Serialize)]
pub struct ReplayReport {
    pub identical: bool,
    pub compared_messages: u64,
    pub last_frame_compared: u64,
    pub recording_truncated: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub divergence: Option<String>,
}

pub fn build<'a>(mode: &'a str, r: &'a MissionResult, replay: Option<ReplayReport>) -> Report<'a> {
    let c = &r.counters;
    Report {
        mode,
        frames: r.frames,
        sim_time_s: r.sim_time_s,
        wall_time_s: r.wall_time_s,
        output_hash: format!("{:016x}", r.output_hash),
        input_hash: format!("{:016x}", r.input_hash),
        scheduler: SchedulerReport {
            minor_frame_us: r.minor_frame_us,
            slips: r.slips,
            allocations_after_init: r.allocations_after_init,
            budgeted_allocations: r.budgeted_allocations,
            housekeeping_allocations: r.housekeeping_allocations,
            mode_at_end: mode_name(r.mode),
            safe_mode_cause: r.safe_mode_cause.as_deref(),
            suppressed_overrun_events: r.suppressed_events,
            tasks: &r.tasks,
        },
        recorder: RecorderReport {
            outputs: r.recorder.outputs,
            written: r.recorder.written,
            dropped_no_buffer: r.recorder.dropped_no_buffer,
            too_large: r.recorder.too_large,
            writer_failed: r.recorder.writer_gone,
        },
        counters: serde_json::json!({
            "imu_frames": c.imu.frames,
            "imu_bad_checksums": c.imu.bad_checksums,
            "imu_skipped_bytes": c.imu.skipped_bytes,
            "imu_bad_items": c.imu_bad_items,
            "imu_samples_lost": c.imu_samples_lost,
            "can_frames": c.can_frames,
            "can_malformed": c.can_malformed,
            "can_unmapped": c.can_unmapped,
            "can_transport_dropped": c.can_transport_dropped,
            "can_bad_length": c.can_bad_length,
            "raw_dropped": c.raw_dropped,
            "hal_errors": c.hal_errors,
            "lidar_packets": r.lidar.packets,
            "lidar_lost_packets": r.lidar.lost_packets,
            "lidar_frames": r.lidar.frames,
            "lidar_position_packets": r.lidar.position_packets,
            "lidar_bad_position_packets": r.lidar.bad_position_packets,
        }),
        replay,
        slam: r.slam.as_ref(),
        maps: r.maps_figures.as_ref(),
        planner: r.planner.as_ref(),
        exploration: r.exploration.as_ref(),
        internal_sim: r.internal_sim.as_ref(),
        faults: &r.faults,
        success: r.success.as_ref(),
        memory: r.memory,
        live: r.live,
        realtime: r.realtime.as_ref(),
        end: r.end,
    }
}

pub fn write(path: &std::path::Path, report: &Report<'_>) -> Result<(), String> {
    write_json(path, report)
}

/// Any serialisable report as pretty JSON.
pub fn write_json(path: &std::path::Path, value: &impl serde::Serialize) -> Result<(), String> {
    let text = serde_json::to_string_pretty(value).map_err(|e| e.to_string())?;
    std::fs::write(path, text + "\n").map_err(|e| format!("cannot write {}: {e}", path.display()))
}
