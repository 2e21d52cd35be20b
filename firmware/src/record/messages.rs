//! The recorded form of the bus's messages: JSON bodies (Foxglove's
//! schemas where one exists), scene lines for paths, CDR point clouds, and
//! the names of states as the recording spells them.

use serde::Serialize;
use speleo_hal::Device;
use speleo_messages::Counters;
use speleo_scheduler::Mode;

use speleo_hal::canopen::supervisor::{DrivesState, StopReasons};
use speleo_hal::xsens_config::ConfigState;
use speleo_health::{finding, SOURCE_NAMES};
use speleo_messages::HealthReport;
use speleo_scheduler::mailbox::Stamped as Published;

use crate::record::encode::{Color, Pose, Quaternion, SeqOf, Time, Vector3, WheelJson};
use crate::record::{RecorderTap, Topic};

pub(crate) fn raw_topic(d: Device) -> Topic {
    match d {
        Device::Lidar => Topic::RawLidar,
        Device::LidarPosition => Topic::RawLidarPosition,
        Device::Imu => Topic::RawImu,
        Device::Can => Topic::RawCan,
    }
}

#[derive(Serialize)]
pub(crate) struct Stamped<T> {
    pub(crate) timestamp: Time,
    #[serde(flatten)]
    pub(crate) body: T,
}

#[derive(Serialize)]
pub(crate) struct HealthJson<'a, S: Serialize, F: Serialize> {
    pub(crate) timestamp: Time,
    pub(crate) mode: &'a str,
    pub(crate) imu_config: &'a str,
    pub(crate) stale: S,
    pub(crate) findings: F,
    pub(crate) drive_faults: u8,
    pub(crate) counters: CountersJson,
}

#[derive(Serialize)]
pub(crate) struct CountersJson {
    imu_frames: u64,
    imu_bad_checksums: u64,
    imu_skipped_bytes: u64,
    imu_oversize: u64,
    imu_bad_items: u64,
    imu_other_messages: u64,
    imu_samples_lost: u64,
    can_frames: u64,
    can_malformed: u64,
    can_unmapped: u64,
    can_bad_length: u64,
    can_tx_dropped: u64,
    raw_dropped: u64,
    hal_errors: u64,
    can_errors: u64,
}

impl From<&Counters> for CountersJson {
    fn from(c: &Counters) -> Self {
        CountersJson {
            imu_frames: c.imu.frames,
            imu_bad_checksums: c.imu.bad_checksums,
            imu_skipped_bytes: c.imu.skipped_bytes,
            imu_oversize: c.imu.oversize,
            imu_bad_items: c.imu_bad_items,
            imu_other_messages: c.imu_other_messages,
            imu_samples_lost: c.imu_samples_lost,
            can_frames: c.can_frames,
            can_malformed: c.can_malformed,
            can_unmapped: c.can_unmapped,
            can_bad_length: c.can_bad_length,
            can_tx_dropped: c.can_tx_dropped,
            raw_dropped: c.raw_dropped,
            hal_errors: c.hal_errors,
            can_errors: c.can_errors,
        }
    }
}

pub fn imu_config_name(s: speleo_hal::xsens_config::ConfigState) -> &'static str {
    use speleo_hal::xsens_config::{ConfigFailure, ConfigState::*};
    match s {
        GoingToConfig => "going_to_config",
        SettingOutputs => "setting_outputs",
        GoingToMeasurement => "going_to_measurement",
        Measuring => "measuring",
        Failed(ConfigFailure::DeviceError { .. }) => "failed_device_error",
        Failed(ConfigFailure::NoAnswer { .. }) => "failed_no_answer",
        Failed(ConfigFailure::ConfigMismatch) => "failed_config_mismatch",
    }
}

pub fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Nominal => "nominal",
        Mode::Safe => "safe",
    }
}

/// One polyline of a `foxglove.SceneUpdate`.
pub(crate) struct SceneLine {
    pub(crate) frame_id: &'static str,
    pub(crate) id: &'static str,
    pub(crate) looped: bool,
    /// r, g, b.
    pub(crate) color: [f64; 3],
}

/// A `foxglove.SceneUpdate` with one line entity through `points`.
pub(crate) fn emit_line(
    tap: &mut RecorderTap,
    topic: Topic,
    frame: u64,
    now: u64,
    stamp_ns: u64,
    line: &SceneLine,
    points: impl Iterator<Item = [f64; 3]>,
) {
    #[derive(Serialize)]
    struct Point {
        x: f64,
        y: f64,
        z: f64,
    }
    #[derive(Serialize)]
    struct Line<P> {
        #[serde(rename = "type")]
        kind: u8,
        pose: Pose,
        thickness: f64,
        scale_invariant: bool,
        points: P,
        color: Color,
        colors: [u8; 0],
        indices: [u8; 0],
    }
    #[derive(Serialize)]
    struct Entity<'a, P> {
        timestamp: Time,
        frame_id: &'a str,
        id: &'a str,
        lifetime: Time,
        frame_locked: bool,
        metadata: [u8; 0],
        arrows: [u8; 0],
        cubes: [u8; 0],
        spheres: [u8; 0],
        cylinders: [u8; 0],
        lines: [Line<P>; 1],
        triangles: [u8; 0],
        texts: [u8; 0],
        models: [u8; 0],
    }
    #[derive(Serialize)]
    struct SceneUpdate<'a, P> {
        deletions: [u8; 0],
        entities: [Entity<'a, P>; 1],
    }
    let points = SeqOf::new(points.map(|p| Point {
        x: p[0],
        y: p[1],
        z: p[2],
    }));
    let [r, g, b] = line.color;
    let msg = SceneUpdate {
        deletions: [],
        entities: [Entity {
            timestamp: tap.time(stamp_ns),
            frame_id: line.frame_id,
            id: line.id,
            lifetime: Time { sec: 0, nsec: 0 },
            frame_locked: false,
            metadata: [],
            arrows: [],
            cubes: [],
            spheres: [],
            cylinders: [],
            lines: [Line {
                // Line strip, or line loop.
                kind: if line.looped { 1 } else { 0 },
                pose: Pose {
                    position: Vector3 {
                        x: 0.0,
                        y: 0.0,
                        z: 0.0,
                    },
                    orientation: Quaternion::wxyz([1.0, 0.0, 0.0, 0.0]),
                },
                thickness: 0.05,
                scale_invariant: false,
                points,
                color: Color { r, g, b, a: 1.0 },
                colors: [],
                indices: [],
            }],
            triangles: [],
            texts: [],
            models: [],
        }],
    };
    // Hundreds of points (~60 bytes each in JSON) outgrow a small message
    // buffer: the line goes in a point-cloud-sized one.
    tap.emit_large(topic, frame, now, stamp_ns, |w| {
        serde_json::to_writer(w, &msg).map_err(std::io::Error::other)
    });
}

/// A `sensor_msgs/PointCloud2` in CDR: an unordered cloud of 20-byte points
/// (x, y, z and the firing time since the revolution's stamp as float32,
/// intensity and ring as uint8, 2 bytes padding), written point by point so
/// no buffer beyond the message itself is needed.
pub(crate) fn write_cloud(
    w: &mut crate::record::encode::Bounded<'_>,
    ts: Time,
    points: &[speleo_hal::hdl32e::Point],
) -> std::io::Result<()> {
    use crate::record::cdr::CdrWriter;
    const STRIDE: u32 = 20;
    const FLOAT32: u8 = 7;
    const UINT8: u8 = 2;
    const FIELDS: [(&str, u32, u8); 6] = [
        ("x", 0, FLOAT32),
        ("y", 4, FLOAT32),
        ("z", 8, FLOAT32),
        ("time", 12, FLOAT32),
        ("intensity", 16, UINT8),
        ("ring", 17, UINT8),
    ];
    let mut c = CdrWriter::new(w)?;
    c.time(ts.sec, ts.nsec)?;
    c.string("lidar")?;
    c.u32(1)?;
    c.u32(points.len() as u32)?;
    c.sequence_len(FIELDS.len())?;
    for (name, offset, datatype) in FIELDS {
        c.string(name)?;
        c.u32(offset)?;
        c.u8(datatype)?;
        c.u32(1)?;
    }
    c.bool(false)?;
    c.u32(STRIDE)?;
    c.u32(STRIDE * points.len() as u32)?;
    c.sequence_len(points.len() * STRIDE as usize)?;
    let mut raw = [0u8; STRIDE as usize];
    for p in points {
        raw[0..4].copy_from_slice(&p.x.to_le_bytes());
        raw[4..8].copy_from_slice(&p.y.to_le_bytes());
        raw[8..12].copy_from_slice(&p.z.to_le_bytes());
        raw[12..16].copy_from_slice(&p.time.to_le_bytes());
        raw[16] = p.intensity;
        raw[17] = p.ring;
        c.bytes_part(&raw)?;
    }
    c.bool(true)
}

#[derive(Serialize)]
pub(crate) struct StopJson {
    holding: bool,
    safe_mode: bool,
    no_command: bool,
    stale_command: bool,
    heartbeat_lost: u8,
    fault: u8,
    not_ready: u8,
    sdo_refused: u8,
    bad_command: bool,
}

impl From<speleo_hal::canopen::supervisor::StopReasons> for StopJson {
    fn from(r: speleo_hal::canopen::supervisor::StopReasons) -> Self {
        StopJson {
            holding: r.any(),
            safe_mode: r.safe_mode,
            no_command: r.no_command,
            stale_command: r.stale_command,
            heartbeat_lost: r.heartbeat_lost,
            fault: r.fault,
            not_ready: r.not_ready,
            sdo_refused: r.sdo_refused,
            bad_command: r.bad_command,
        }
    }
}

pub fn nmt_name(s: speleo_hal::canopen::NmtState) -> &'static str {
    use speleo_hal::canopen::NmtState::*;
    match s {
        BootUp => "boot_up",
        Stopped => "stopped",
        Operational => "operational",
        PreOperational => "pre_operational",
    }
}

pub fn state_name(s: speleo_hal::cia402::DriveState) -> &'static str {
    use speleo_hal::cia402::DriveState::*;
    match s {
        NotReadyToSwitchOn => "not_ready_to_switch_on",
        SwitchOnDisabled => "switch_on_disabled",
        ReadyToSwitchOn => "ready_to_switch_on",
        SwitchedOn => "switched_on",
        OperationEnabled => "operation_enabled",
        QuickStopActive => "quick_stop_active",
        FaultReactionActive => "fault_reaction_active",
        Fault => "fault",
        Unknown => "unknown",
    }
}

/// The drives' feedback `d` and why the output holds the wheels (`stop`)
/// as one `/drives` message.
pub(crate) fn emit_drives(
    tap: &mut RecorderTap,
    frame: u64,
    now: u64,
    d: &Published<DrivesState>,
    stop: StopReasons,
) {
    let wheels = SeqOf::new(d.value.nodes.iter().map(|n| WheelJson {
        state: state_name(n.state),
        statusword: n.statusword,
        velocity_rad_s: n.velocity as f64 * 1e-3,
        position_counts: n.position,
        torque_nm: n.torque.map(speleo_hal::cia402::torque_nm),
        nmt: n.nmt.map_or("unknown", nmt_name),
        profile_velocity_mode: n.mode_set,
        emergencies: n.emergencies,
        last_emergency: n.last_emergency,
    }));
    #[derive(Serialize)]
    struct Drives<S> {
        wheels: S,
        stop: StopJson,
    }
    let msg = Stamped {
        timestamp: tap.time(d.stamp_ns),
        body: Drives {
            wheels,
            stop: StopJson::from(stop),
        },
    };
    tap.emit(Topic::Drives, frame, now, d.stamp_ns, |w| {
        serde_json::to_writer(w, &msg)
    });
}

/// The health report `h` with the executive's mode, the IMU's
/// configuration state and the counters as one `/health` message.
pub(crate) fn emit_health(
    tap: &mut RecorderTap,
    (frame, now): (u64, u64),
    h: &Published<HealthReport>,
    mode: Mode,
    imu_config: ConfigState,
    counters: &Counters,
) {
    let mask = h.value.stale_mask;
    let msg = HealthJson {
        timestamp: tap.time(h.stamp_ns),
        mode: if h.value.safe_mode {
            "safe"
        } else {
            mode_name(mode)
        },
        imu_config: imu_config_name(imu_config),
        stale: SeqOf::new(
            SOURCE_NAMES
                .iter()
                .enumerate()
                .filter(move |(i, _)| mask & (1 << i) != 0)
                .map(|(_, n)| *n),
        ),
        findings: SeqOf::new(finding::names(h.value.findings)),
        drive_faults: h.value.drive_faults,
        counters: CountersJson::from(counters),
    };
    tap.emit(Topic::Health, frame, now, h.stamp_ns, |w| {
        serde_json::to_writer(w, &msg)
    });
}
