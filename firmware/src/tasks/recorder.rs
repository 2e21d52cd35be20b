//! Taps every mailbox once per frame and records what is new: the frame's raw
//! inputs, the CAN frames queued for the drives, IMU samples, drive feedback,
//! odometry (pose and transform), wheel commands, health, and the path.

use std::cell::RefCell;

use serde::Serialize;
use speleo_hal::Device;
use speleo_scheduler::{Context, Mode, Task};

use crate::bus::Bus;
use crate::record::encode::{
    CanFrameJson, Color, FrameTransform, ImuSampleJson, Pose, PoseInFrame, Quaternion, SeqOf, Time,
    Vector3, WheelCommandJson, WheelJson,
};
use crate::record::{RecorderTap, Topic};
use crate::tasks::health::{finding, SOURCE_NAMES};
use speleo_messages::Counters;

/// The path is re-sent this often (frames) so a viewer that seeks finds it.
pub const PLAN_EVERY_FRAMES: u64 = 100;

pub struct RecorderTask<'r> {
    tap: &'r RefCell<RecorderTap>,
    imu_cursor: u64,
    drives_seen: u64,
    odom_seen: u64,
    slam_seen: u64,
    planner_seen: u64,
    command_seen: u64,
    health_seen: u64,
    plan: Vec<[f64; 2]>,
    plan_looped: bool,
    cloud_seen: u64,
    /// Record one revolution in this many (the raw packets hold them all).
    cloud_every: u64,
    /// base_link -> lidar: translation and (w, x, y, z) rotation.
    lidar_mount: ([f64; 3], [f64; 4]),
}

impl<'r> RecorderTask<'r> {
    pub fn new(
        tap: &'r RefCell<RecorderTap>,
        plan: Vec<[f64; 2]>,
        plan_looped: bool,
        mount_xyz: [f64; 3],
        mount_rpy_deg: [f64; 3],
    ) -> Self {
        let [r, p, y] = mount_rpy_deg.map(f64::to_radians);
        let q = nalgebra::UnitQuaternion::from_euler_angles(r, p, y).into_inner();
        RecorderTask {
            cloud_seen: 0,
            cloud_every: 1,
            lidar_mount: (mount_xyz, [q.w, q.i, q.j, q.k]),
            tap,
            imu_cursor: 0,
            drives_seen: 0,
            odom_seen: 0,
            slam_seen: 0,
            planner_seen: 0,
            command_seen: 0,
            health_seen: 0,
            plan,
            plan_looped,
        }
    }

    /// Record only every `n`th decoded revolution.
    pub fn with_cloud_every(mut self, n: u32) -> Self {
        self.cloud_every = n.max(1) as u64;
        self
    }
}

fn raw_topic(d: Device) -> Topic {
    match d {
        Device::Lidar => Topic::RawLidar,
        Device::LidarPosition => Topic::RawLidarPosition,
        Device::Imu => Topic::RawImu,
        Device::Can => Topic::RawCan,
    }
}

#[derive(Serialize)]
struct Stamped<T> {
    timestamp: Time,
    #[serde(flatten)]
    body: T,
}

#[derive(Serialize)]
struct HealthJson<'a, S: Serialize, F: Serialize> {
    timestamp: Time,
    mode: &'a str,
    imu_config: &'a str,
    stale: S,
    findings: F,
    drive_faults: u8,
    counters: CountersJson,
}

#[derive(Serialize)]
struct CountersJson {
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

impl Task<Bus> for RecorderTask<'_> {
    fn run(&mut self, bus: &mut Bus, cx: &Context) {
        let Ok(mut tap) = self.tap.try_borrow_mut() else {
            return;
        };
        let (frame, now) = (cx.frame, cx.time_ns);

        for e in bus.raw.entries() {
            let bytes = bus.raw.bytes_of(e);
            tap.raw(
                raw_topic(e.device),
                e.device.name(),
                frame,
                now,
                e.receive_time_ns,
                bytes,
            );
        }

        for m in bus.imu_tx.iter() {
            tap.raw(Topic::ImuTx, "imu", frame, now, now, m);
        }

        if !bus.can_tx.is_empty() {
            let ts = tap.time(now);
            let frames = SeqOf::new(bus.can_tx.iter().map(|f| CanFrameJson {
                id: f.id,
                data: f.payload(),
            }));
            #[derive(Serialize)]
            struct Frames<S> {
                frames: S,
            }
            let msg = Stamped {
                timestamp: ts,
                body: Frames { frames },
            };
            tap.emit(Topic::CanTx, frame, now, now, |w| {
                serde_json::to_writer(w, &msg)
            });
        }

        let tap_ref = &mut *tap;
        bus.imu.read_since(&mut self.imu_cursor, |s| {
            let v = &s.value;
            let msg = ImuSampleJson {
                timestamp: tap_ref.time(s.stamp_ns),
                packet_counter: v.packet_counter,
                sample_time_fine: v.sample_time_fine,
                orientation: Quaternion::wxyz(v.orientation),
                acceleration: v.acceleration.into(),
                rate_of_turn: v.rate_of_turn.into(),
                status_word: v.status_word,
            };
            tap_ref.emit(Topic::Imu, frame, now, s.stamp_ns, |w| {
                serde_json::to_writer(w, &msg)
            });
        });

        if let Some(d) = bus.drives.newer_than(self.drives_seen) {
            self.drives_seen = d.seq;
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
            let stop = bus.drive_stop.get().map(|s| s.value).unwrap_or_default();
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

        if let Some(c) = bus
            .cloud
            .newer_than(self.cloud_seen)
            .filter(|c| (c.seq - 1).is_multiple_of(self.cloud_every))
        {
            self.cloud_seen = c.seq;
            let ts = tap.time(c.stamp_ns);
            let points = &c.value.points;
            tap.emit_large(Topic::Cloud, frame, now, c.stamp_ns, |w| {
                write_cloud(w, ts, points)
            });
            let (xyz, q) = self.lidar_mount;
            let tf = FrameTransform {
                timestamp: ts,
                parent_frame_id: "base_link",
                child_frame_id: "lidar",
                translation: xyz.into(),
                rotation: Quaternion::wxyz(q),
            };
            tap.emit(Topic::Tf, frame, now, c.stamp_ns, |w| {
                serde_json::to_writer(w, &tf)
            });
        }

        if let Some(o) = bus.odom.newer_than(self.odom_seen) {
            self.odom_seen = o.seq;
            let ts = tap.time(o.stamp_ns);
            let pose = PoseInFrame {
                timestamp: ts,
                frame_id: "odom",
                pose: Pose {
                    position: o.value.position.into(),
                    orientation: Quaternion::wxyz(o.value.orientation),
                },
            };
            tap.emit(Topic::Odom, frame, now, o.stamp_ns, |w| {
                serde_json::to_writer(w, &pose)
            });
            let tf = FrameTransform {
                timestamp: ts,
                parent_frame_id: "odom",
                child_frame_id: "base_link",
                translation: o.value.position.into(),
                rotation: Quaternion::wxyz(o.value.orientation),
            };
            tap.emit(Topic::Tf, frame, now, o.stamp_ns, |w| {
                serde_json::to_writer(w, &tf)
            });
        }

        if let Some(o) = bus.slam.newer_than(self.slam_seen) {
            self.slam_seen = o.seq;
            // Only once SLAM has a map (before its first keyframe it repeats
            // the odometry).
            if o.value.keyframes > 0 {
                let pose = PoseInFrame {
                    timestamp: tap.time(o.stamp_ns),
                    frame_id: "map",
                    pose: Pose {
                        position: o.value.position.into(),
                        orientation: Quaternion::wxyz(o.value.orientation),
                    },
                };
                tap.emit(Topic::SlamPose, frame, now, o.stamp_ns, |w| {
                    serde_json::to_writer(w, &pose)
                });
            }
        }

        if let Some(c) = bus.command.newer_than(self.command_seen) {
            self.command_seen = c.seq;
            let msg = WheelCommandJson {
                timestamp: tap.time(c.stamp_ns),
                speed: c.value.speed,
                yaw_rate: c.value.yaw_rate,
                wheel_speeds: c.value.wheel_speeds,
                segment: c.value.segment,
                done: c.value.done,
            };
            tap.emit(Topic::WheelCommand, frame, now, c.stamp_ns, |w| {
                serde_json::to_writer(w, &msg)
            });
        }

        if let Some(h) = bus.health.newer_than(self.health_seen) {
            self.health_seen = h.seq;
            let mask = h.value.stale_mask;
            let msg = HealthJson {
                timestamp: tap.time(h.stamp_ns),
                mode: if h.value.safe_mode {
                    "safe"
                } else {
                    mode_name(cx.mode)
                },
                imu_config: imu_config_name(bus.imu_config),
                stale: SeqOf::new(
                    SOURCE_NAMES
                        .iter()
                        .enumerate()
                        .filter(move |(i, _)| mask & (1 << i) != 0)
                        .map(|(_, n)| *n),
                ),
                findings: SeqOf::new(finding::names(h.value.findings)),
                drive_faults: h.value.drive_faults,
                counters: CountersJson::from(&bus.counters),
            };
            tap.emit(Topic::Health, frame, now, h.stamp_ns, |w| {
                serde_json::to_writer(w, &msg)
            });
        }

        if frame % PLAN_EVERY_FRAMES == 0 {
            let route = self.plan.iter().map(|p| [p[0], p[1], 0.0]);
            let looped = self.plan_looped;
            let line = SceneLine {
                frame_id: "odom",
                id: "plan",
                looped,
                color: [0.1, 0.8, 0.3],
            };
            emit_line(&mut tap, Topic::Plan, frame, now, now, &line, route);
        }
        if let Some(p) = bus.plan.newer_than(self.planner_seen) {
            self.planner_seen = p.seq;
            // The planner's path over the ground, in the SLAM map frame.
            let poses = p
                .value
                .poses
                .iter()
                .map(|q| [q[0] as f64, q[1] as f64, q[2] as f64]);
            let line = SceneLine {
                frame_id: "map",
                id: "planner_path",
                looped: false,
                color: if p.value.optimal {
                    [0.2, 0.4, 1.0]
                } else {
                    [1.0, 0.6, 0.1]
                },
            };
            emit_line(
                &mut tap,
                Topic::PlannerPath,
                frame,
                now,
                p.stamp_ns,
                &line,
                poses,
            );
        }
        if let Some(c) = tap.comparer_mut() {
            c.end_frame(frame);
        }
    }

    fn set_degraded(&mut self, _degraded: bool) {
        // The recorder has no reduced mode: losing records is worse than
        // losing time, and in real time the pool already drops (and counts)
        // what the disk cannot take.
    }
}

/// One polyline of a `foxglove.SceneUpdate`.
struct SceneLine {
    frame_id: &'static str,
    id: &'static str,
    looped: bool,
    /// r, g, b.
    color: [f64; 3],
}

/// A `foxglove.SceneUpdate` with one line entity through `points`.
fn emit_line(
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
fn write_cloud(
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
struct StopJson {
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
