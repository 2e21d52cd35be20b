//! The recorded form of the bus's device and command messages as ROS 2
//! types in CDR (standard messages where one exists, `speleo_msgs` for the
//! rest), and the names of states as the recording spells them.

use speleo_hal::can::CanFrame;
use speleo_hal::Device;
use speleo_messages::ImuSample;
use speleo_scheduler::Mode;

use speleo_hal::canopen::supervisor::{DrivesState, StopReasons};
use speleo_scheduler::mailbox::Stamped as Published;

use crate::record::cdr::CdrWriter;
use crate::record::encode::Time;
use crate::record::ros2::{header, pose, quaternion, unknown_covariance, vector3};
use crate::record::{RecorderTap, Topic};

pub(crate) fn raw_topic(d: Device) -> Topic {
    match d {
        Device::Lidar => Topic::RawLidar,
        Device::LidarPosition => Topic::RawLidarPosition,
        Device::Imu => Topic::RawImu,
        Device::Can => Topic::RawCan,
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

/// One polyline drawn as a `visualization_msgs/Marker`.
pub(crate) struct MarkerLine {
    pub(crate) frame_id: &'static str,
    pub(crate) ns: &'static str,
    /// Close the line back to its first point.
    pub(crate) looped: bool,
    /// r, g, b.
    pub(crate) color: [f32; 3],
}

/// A `visualization_msgs/MarkerArray` with one LINE_STRIP marker through
/// `points` (in a large buffer: a route has hundreds of points).
pub(crate) fn emit_marker_line<I>(
    tap: &mut RecorderTap,
    topic: Topic,
    (frame, now, stamp_ns): (u64, u64, u64),
    line: &MarkerLine,
    points: I,
) where
    I: Iterator<Item = [f64; 3]> + Clone,
{
    const LINE_STRIP: i32 = 4;
    const ADD: i32 = 0;
    let stamp = tap.time(stamp_ns);
    let first = points.clone().next();
    let closing = first.filter(|_| line.looped);
    let n = points.clone().count() + closing.is_some() as usize;
    tap.emit_large(topic, frame, now, stamp_ns, |w| {
        let mut c = CdrWriter::new(w)?;
        c.sequence_len(1)?;
        header(&mut c, stamp, line.frame_id)?;
        c.string(line.ns)?;
        c.i32(0)?;
        c.i32(LINE_STRIP)?;
        c.i32(ADD)?;
        pose(&mut c, [0.0; 3], [1.0, 0.0, 0.0, 0.0])?;
        // scale.x is the line's width.
        vector3(&mut c, [0.05, 0.0, 0.0])?;
        let [r, g, b] = line.color;
        [r, g, b, 1.0].iter().try_for_each(|v| c.f32(*v))?;
        // Lifetime zero: until replaced; not frame-locked.
        c.time(0, 0)?;
        c.bool(false)?;
        c.sequence_len(n)?;
        for p in points.chain(closing) {
            vector3(&mut c, p)?;
        }
        // colors, texture_resource, texture (header, format, data),
        // uv_coordinates, text, mesh_resource, mesh_file, embedded materials.
        c.sequence_len(0)?;
        c.string("")?;
        header(&mut c, Time { sec: 0, nsec: 0 }, "")?;
        c.string("")?;
        c.bytes(&[])?;
        c.sequence_len(0)?;
        c.string("")?;
        c.string("")?;
        c.string("")?;
        c.bytes(&[])?;
        c.bool(false)
    });
}

/// A `nav_msgs/Path` through `poses` (x, y, z, yaw) in `frame_id`.
pub(crate) fn emit_path<I>(
    tap: &mut RecorderTap,
    topic: Topic,
    (frame, now, stamp_ns): (u64, u64, u64),
    frame_id: &str,
    poses: I,
) where
    I: ExactSizeIterator<Item = [f64; 4]>,
{
    let stamp = tap.time(stamp_ns);
    tap.emit_large(topic, frame, now, stamp_ns, |w| {
        let mut c = CdrWriter::new(w)?;
        header(&mut c, stamp, frame_id)?;
        c.sequence_len(poses.len())?;
        for [x, y, z, yaw] in poses {
            let half = 0.5 * yaw;
            header(&mut c, stamp, frame_id)?;
            pose(&mut c, [x, y, z], [half.cos(), 0.0, 0.0, half.sin()])?;
        }
        Ok(())
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
/// as one `speleo_msgs/DriveFeedback`.
pub(crate) fn emit_drives(
    tap: &mut RecorderTap,
    frame: u64,
    now: u64,
    d: &Published<DrivesState>,
    stop: StopReasons,
) {
    let stamp = tap.time(d.stamp_ns);
    tap.emit(Topic::Drives, frame, now, d.stamp_ns, |w| {
        let mut c = CdrWriter::new(w)?;
        header(&mut c, stamp, "base_link")?;
        for n in &d.value.nodes {
            c.string(state_name(n.state))?;
            c.u16(n.statusword)?;
            c.f64(n.velocity as f64 * 1e-3)?;
            c.i32(n.position)?;
            let torque = n.torque.map(speleo_hal::cia402::torque_nm);
            c.bool(torque.is_some())?;
            c.f64(torque.unwrap_or(0.0))?;
            c.string(n.nmt.map_or("unknown", nmt_name))?;
            c.bool(n.mode_set)?;
            c.u32(n.emergencies)?;
            c.u16(n.last_emergency)?;
        }
        c.bool(stop.any())?;
        c.bool(stop.safe_mode)?;
        c.bool(stop.no_command)?;
        c.bool(stop.stale_command)?;
        c.u8(stop.heartbeat_lost)?;
        c.u8(stop.fault)?;
        c.u8(stop.not_ready)?;
        c.u8(stop.sdo_refused)?;
        c.bool(stop.bad_command)
    });
}

/// One IMU sample as `sensor_msgs/Imu` (frame `imu`, covariances unknown)
/// and the fields it has no place for as `speleo_msgs/ImuStatus`.
pub(crate) fn emit_imu(tap: &mut RecorderTap, (frame, now): (u64, u64), s: &Published<ImuSample>) {
    let v = &s.value;
    let stamp = tap.time(s.stamp_ns);
    tap.emit(Topic::Imu, frame, now, s.stamp_ns, |w| {
        let mut c = CdrWriter::new(w)?;
        header(&mut c, stamp, "imu")?;
        quaternion(&mut c, v.orientation)?;
        unknown_covariance(&mut c, 9)?;
        vector3(&mut c, v.rate_of_turn)?;
        unknown_covariance(&mut c, 9)?;
        vector3(&mut c, v.acceleration)?;
        unknown_covariance(&mut c, 9)
    });
    tap.emit(Topic::ImuStatus, frame, now, s.stamp_ns, |w| {
        let mut c = CdrWriter::new(w)?;
        header(&mut c, stamp, "imu")?;
        c.u16(v.packet_counter)?;
        c.u32(v.sample_time_fine)?;
        c.u32(v.status_word)
    });
}

/// The `n` CAN frames queued for the drives in this frame, as
/// `speleo_msgs/CanFrames`.
pub(crate) fn emit_can_tx<'f>(
    tap: &mut RecorderTap,
    (frame, now): (u64, u64),
    n: usize,
    frames: impl Iterator<Item = &'f CanFrame>,
) {
    let stamp = tap.time(now);
    tap.emit(Topic::CanTx, frame, now, now, |w| {
        let mut c = CdrWriter::new(w)?;
        header(&mut c, stamp, "can")?;
        c.sequence_len(n)?;
        for f in frames.take(n) {
            c.u32(f.id)?;
            c.bytes(f.payload())?;
        }
        Ok(())
    });
}

/// The path follower's command as `speleo_msgs/WheelCommand`.
pub(crate) fn emit_wheel_command(
    tap: &mut RecorderTap,
    (frame, now): (u64, u64),
    c: &Published<speleo_messages::WheelCommand>,
) {
    let stamp = tap.time(c.stamp_ns);
    let v = &c.value;
    tap.emit(Topic::WheelCommand, frame, now, c.stamp_ns, |w| {
        let mut c = CdrWriter::new(w)?;
        header(&mut c, stamp, "base_link")?;
        c.f64(v.speed)?;
        c.f64(v.yaw_rate)?;
        v.wheel_speeds.iter().try_for_each(|s| c.f64(*s))?;
        c.u32(v.segment)?;
        c.bool(v.done)
    });
}
