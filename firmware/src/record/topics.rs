//! Every recorded topic, its schema and its role. Channel ids are fixed by
//! this table, so recordings of the same software always agree.

use super::cdr;

/// What a topic carries, which decides how replay treats it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Raw hardware input, fed back by replay.
    Input,
    /// A task output: hashed, and compared field by field in replay.
    Output,
    /// Measured execution times: depends on the machine, never compared.
    Telemetry,
    /// Simulation ground truth: never visible to on-board tasks, not compared.
    Sim,
}

impl Role {
    pub fn as_str(&self) -> &'static str {
        match self {
            Role::Input => "input",
            Role::Output => "output",
            Role::Telemetry => "telemetry",
            Role::Sim => "sim",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Topic {
    RawLidar,
    RawLidarPosition,
    RawImu,
    RawCan,
    ImuTx,
    CanTx,
    Imu,
    Cloud,
    Drives,
    Odom,
    Tf,
    WheelCommand,
    Plan,
    Health,
    Scheduler,
    GroundTruth,
    SimTf,
    /// The SLAM pose in the map frame (added last: channel ids stay stable).
    SlamPose,
    /// The planner's latest path.
    PlannerPath,
}

pub struct TopicInfo {
    pub topic: Topic,
    pub name: &'static str,
    pub schema: &'static str,
    /// The schema's text: a JSON schema, or a ros2msg definition for CDR.
    pub schema_data: &'static str,
    /// Raw bytes and point clouds are CDR (`ros2msg` schemas); the rest JSON.
    pub cdr: bool,
    pub role: Role,
}

impl TopicInfo {
    /// MCAP's schema encoding.
    pub fn schema_encoding(&self) -> &'static str {
        if self.cdr {
            "ros2msg"
        } else {
            "jsonschema"
        }
    }

    /// MCAP's message encoding.
    pub fn message_encoding(&self) -> &'static str {
        if self.cdr {
            "cdr"
        } else {
            "json"
        }
    }
}

const RAW: &str = "speleo_msgs/msg/RawInput";

impl Topic {
    pub const ALL: [Topic; 19] = [
        Topic::RawLidar,
        Topic::RawLidarPosition,
        Topic::RawImu,
        Topic::RawCan,
        Topic::ImuTx,
        Topic::CanTx,
        Topic::Imu,
        Topic::Cloud,
        Topic::Drives,
        Topic::Odom,
        Topic::Tf,
        Topic::WheelCommand,
        Topic::Plan,
        Topic::Health,
        Topic::Scheduler,
        Topic::GroundTruth,
        Topic::SimTf,
        Topic::SlamPose,
        Topic::PlannerPath,
    ];

    /// Position in the data flow (decoded inputs first, commands to the
    /// devices last): within one frame, a divergence in a lower rank is the
    /// cause of those in higher ranks.
    pub fn flow_rank(self) -> u8 {
        match self {
            Topic::RawLidar | Topic::RawLidarPosition | Topic::RawImu | Topic::RawCan => 0,
            Topic::Imu | Topic::Cloud | Topic::Drives => 1,
            Topic::Odom | Topic::Tf | Topic::SlamPose => 2,
            Topic::WheelCommand | Topic::Plan | Topic::PlannerPath => 3,
            Topic::Health => 4,
            Topic::ImuTx | Topic::CanTx => 5,
            Topic::Scheduler | Topic::GroundTruth | Topic::SimTf => 6,
        }
    }

    /// MCAP channel id.
    pub fn channel_id(self) -> u16 {
        self as u16 + 1
    }

    pub fn from_channel_id(id: u16) -> Option<Topic> {
        Topic::ALL.get((id as usize).checked_sub(1)?).copied()
    }

    pub fn info(self) -> TopicInfo {
        let (name, schema, schema_data, role) = match self {
            Topic::RawLidar => ("/raw/lidar", RAW, cdr::RAW_INPUT, Role::Input),
            Topic::RawLidarPosition => ("/raw/lidar_position", RAW, cdr::RAW_INPUT, Role::Input),
            Topic::RawImu => ("/raw/imu", RAW, cdr::RAW_INPUT, Role::Input),
            Topic::RawCan => ("/raw/can", RAW, cdr::RAW_INPUT, Role::Input),
            Topic::ImuTx => ("/imu/tx", RAW, cdr::RAW_INPUT, Role::Output),
            Topic::CanTx => ("/can/tx", "speleo.CanFrames", CAN_FRAMES, Role::Output),
            Topic::Imu => ("/imu", "speleo.ImuSample", IMU_SAMPLE, Role::Output),
            Topic::Cloud => (
                "/lidar/points",
                "sensor_msgs/msg/PointCloud2",
                cdr::POINT_CLOUD2,
                Role::Output,
            ),
            Topic::Drives => (
                "/drives",
                "speleo.DriveFeedback",
                DRIVE_FEEDBACK,
                Role::Output,
            ),
            Topic::Odom => ("/odom", "foxglove.PoseInFrame", POSE_IN_FRAME, Role::Output),
            Topic::SlamPose => (
                "/slam/pose",
                "foxglove.PoseInFrame",
                POSE_IN_FRAME,
                Role::Output,
            ),
            Topic::Tf => (
                "/tf",
                "foxglove.FrameTransform",
                FRAME_TRANSFORM,
                Role::Output,
            ),
            Topic::WheelCommand => (
                "/cmd/wheels",
                "speleo.WheelCommand",
                WHEEL_COMMAND,
                Role::Output,
            ),
            Topic::Plan => ("/plan", "foxglove.SceneUpdate", SCENE_UPDATE, Role::Output),
            Topic::PlannerPath => (
                "/planner/path",
                "foxglove.SceneUpdate",
                SCENE_UPDATE,
                Role::Output,
            ),
            Topic::Health => ("/health", "speleo.Health", HEALTH, Role::Output),
            Topic::Scheduler => (
                "/scheduler",
                "speleo.SchedulerTelemetry",
                SCHEDULER,
                Role::Telemetry,
            ),
            Topic::GroundTruth => (
                "/sim/ground_truth",
                "foxglove.PoseInFrame",
                POSE_IN_FRAME,
                Role::Sim,
            ),
            // world -> odom: where the simulated rover started.
            Topic::SimTf => (
                "/sim/tf",
                "foxglove.FrameTransform",
                FRAME_TRANSFORM,
                Role::Sim,
            ),
        };
        TopicInfo {
            topic: self,
            name,
            schema,
            schema_data,
            cdr: schema_data == cdr::RAW_INPUT || schema_data == cdr::POINT_CLOUD2,
            role,
        }
    }

    pub fn by_name(name: &str) -> Option<Topic> {
        Topic::ALL.into_iter().find(|t| t.info().name == name)
    }
}

// Foxglove's JSON schemas (the subset of fields we write is the whole schema
// for these messages), and our own in the same style.

const POSE_IN_FRAME: &str = r#"{"title":"foxglove.PoseInFrame","description":"A timestamped pose for an object or reference frame in 3D space","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}},"frame_id":{"type":"string"},"pose":{"title":"foxglove.Pose","type":"object","properties":{"position":{"title":"foxglove.Vector3","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}},"orientation":{"title":"foxglove.Quaternion","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}}}}}}"#;

const FRAME_TRANSFORM: &str = r#"{"title":"foxglove.FrameTransform","description":"A transform between two reference frames in 3D space","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}},"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},"translation":{"title":"foxglove.Vector3","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}},"rotation":{"title":"foxglove.Quaternion","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}}}}"#;

const SCENE_UPDATE: &str = r#"{"title":"foxglove.SceneUpdate","description":"An update to the entities displayed in a 3D scene","type":"object","properties":{"deletions":{"type":"array","items":{"type":"object"}},"entities":{"type":"array","items":{"title":"foxglove.SceneEntity","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}},"frame_id":{"type":"string"},"id":{"type":"string"},"lifetime":{"type":"object","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"frame_locked":{"type":"boolean"},"metadata":{"type":"array","items":{"type":"object"}},"arrows":{"type":"array"},"cubes":{"type":"array"},"spheres":{"type":"array"},"cylinders":{"type":"array"},"lines":{"type":"array","items":{"title":"foxglove.LinePrimitive","type":"object","properties":{"type":{"type":"integer","description":"0 LINE_STRIP, 1 LINE_LOOP, 2 LINE_LIST"},"pose":{"type":"object"},"thickness":{"type":"number"},"scale_invariant":{"type":"boolean"},"points":{"type":"array","items":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}}},"color":{"type":"object","properties":{"r":{"type":"number"},"g":{"type":"number"},"b":{"type":"number"},"a":{"type":"number"}}},"colors":{"type":"array"},"indices":{"type":"array"}}}},"triangles":{"type":"array"},"texts":{"type":"array"},"models":{"type":"array"}}}}}}"#;

const CAN_FRAMES: &str = r#"{"title":"speleo.CanFrames","description":"CAN frames queued for the bus in this frame (sent at the start of the next)","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"frames":{"type":"array","items":{"type":"object","properties":{"id":{"type":"integer"},"data":{"type":"array","items":{"type":"integer"}}}}}}}"#;

const IMU_SAMPLE: &str = r#"{"title":"speleo.ImuSample","description":"One decoded Xsens MTData2 sample","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"packet_counter":{"type":"integer"},"sample_time_fine":{"type":"integer","description":"10 kHz ticks"},"orientation":{"title":"foxglove.Quaternion","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}},"acceleration":{"title":"foxglove.Vector3","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}},"rate_of_turn":{"title":"foxglove.Vector3","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}},"status_word":{"type":"integer"}}}"#;

const DRIVE_FEEDBACK: &str = r#"{"title":"speleo.DriveFeedback","description":"CiA 402 feedback of the four wheel drives (front left, front right, rear left, rear right)","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"wheels":{"type":"array","items":{"type":"object","properties":{"state":{"type":"string"},"statusword":{"type":"integer"},"velocity_rad_s":{"type":"number"},"position_counts":{"type":"integer"},"torque_nm":{"type":["number","null"],"description":"torque actual at the wheel (0x6077); null when the drive does not map it"},"nmt":{"type":"string"},"profile_velocity_mode":{"type":"boolean"},"emergencies":{"type":"integer"},"last_emergency":{"type":"integer"}}}},"stop":{"type":"object","description":"why the wheels are held at zero; masks have bit w for wheel w","properties":{"holding":{"type":"boolean"},"safe_mode":{"type":"boolean"},"no_command":{"type":"boolean"},"stale_command":{"type":"boolean"},"heartbeat_lost":{"type":"integer"},"fault":{"type":"integer"},"not_ready":{"type":"integer"},"sdo_refused":{"type":"integer"}}}}}"#;

const WHEEL_COMMAND: &str = r#"{"title":"speleo.WheelCommand","description":"Body command and wheel speeds from the path follower","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"speed":{"type":"number"},"yaw_rate":{"type":"number"},"wheel_speeds":{"type":"array","items":{"type":"number"}},"segment":{"type":"integer"},"done":{"type":"boolean"}}}"#;

const HEALTH: &str = r#"{"title":"speleo.Health","description":"Device freshness and decoder counters","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"mode":{"type":"string"},"imu_config":{"type":"string"},"stale":{"type":"array","items":{"type":"string"}},"findings":{"type":"array","items":{"type":"string"}},"drive_faults":{"type":"integer"},"counters":{"type":"object","additionalProperties":{"type":"integer"}}}}"#;

const SCHEDULER: &str = r#"{"title":"speleo.SchedulerTelemetry","description":"Execution-time statistics per task, measured on the monotonic clock","type":"object","properties":{"timestamp":{"type":"object","title":"time","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"frames":{"type":"integer"},"slips":{"type":"integer"},"mode":{"type":"string"},"tasks":{"type":"array","items":{"type":"object","properties":{"name":{"type":"string"},"runs":{"type":"integer"},"overruns":{"type":"integer"},"max_us":{"type":"number"},"p50_us":{"type":"number"},"p99_us":{"type":"number"},"p999_us":{"type":"number"}}}}}}"#;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_schema_is_json_and_ids_round_trip() {
        for t in Topic::ALL {
            let i = t.info();
            if !i.cdr {
                let v: serde_json::Value = serde_json::from_str(i.schema_data).expect(i.name);
                assert_eq!(v["title"], i.schema, "{}", i.name);
            }
            assert_eq!(Topic::from_channel_id(t.channel_id()), Some(t));
            assert_eq!(Topic::by_name(i.name), Some(t));
        }
    }
}
