//! Every recorded topic, its schema and its role. Channel ids are fixed by
//! this table, so recordings of the same software always agree.

use super::schemas;

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
    /// The executive's timing decisions in real time (slips, overruns):
    /// taken again by replay, not compared.
    Schedule,
}

impl Role {
    pub fn as_str(&self) -> &'static str {
        match self {
            Role::Input => "input",
            Role::Output => "output",
            Role::Telemetry => "telemetry",
            Role::Sim => "sim",
            Role::Schedule => "schedule",
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
    /// The rover's fixed frames: base_link to its sensors.
    TfStatic,
    /// The IMU sample's fields that `sensor_msgs/Imu` has no place for.
    ImuStatus,
    /// The executive's slips and overruns in a frame of a real-time run.
    FrameTiming,
}

pub struct TopicInfo {
    pub topic: Topic,
    pub name: &'static str,
    /// The ROS 2 type, as `package/msg/Name`.
    pub schema: &'static str,
    /// The type's `ros2msg` definition with its dependencies.
    pub schema_data: &'static str,
    pub role: Role,
}

impl TopicInfo {
    /// MCAP's schema encoding: every topic is a ROS 2 message.
    pub fn schema_encoding(&self) -> &'static str {
        "ros2msg"
    }

    /// MCAP's message encoding.
    pub fn message_encoding(&self) -> &'static str {
        "cdr"
    }

    /// The QoS a ROS 2 publisher of this topic offers, as rosbag2 records it
    /// (`offered_qos_profiles`), so `ros2 bag play` republishes alike:
    /// reliable, and for `/tf_static` transient local (latched) too.
    pub fn offered_qos(&self) -> &'static str {
        if self.topic == Topic::TfStatic {
            QOS_LATCHED
        } else {
            QOS_RELIABLE
        }
    }
}

const QOS_RELIABLE: &str = "- history: 1\n  depth: 100\n  reliability: 1\n  durability: 2\n  deadline:\n    sec: 2147483647\n    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n  avoid_ros_namespace_conventions: false\n";

const QOS_LATCHED: &str = "- history: 1\n  depth: 1\n  reliability: 1\n  durability: 1\n  deadline:\n    sec: 2147483647\n    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n  avoid_ros_namespace_conventions: false\n";

impl Topic {
    pub const ALL: [Topic; 22] = [
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
        Topic::TfStatic,
        Topic::ImuStatus,
        Topic::FrameTiming,
    ];

    /// Position in the data flow (decoded inputs first, commands to the
    /// devices last): within one frame, a divergence in a lower rank is the
    /// cause of those in higher ranks.
    pub fn flow_rank(self) -> u8 {
        match self {
            Topic::RawLidar | Topic::RawLidarPosition | Topic::RawImu | Topic::RawCan => 0,
            Topic::Imu | Topic::ImuStatus | Topic::Cloud | Topic::Drives => 1,
            Topic::Odom | Topic::Tf | Topic::TfStatic | Topic::SlamPose => 2,
            Topic::WheelCommand | Topic::Plan | Topic::PlannerPath => 3,
            Topic::Health => 4,
            Topic::ImuTx | Topic::CanTx => 5,
            Topic::Scheduler | Topic::GroundTruth | Topic::SimTf | Topic::FrameTiming => 6,
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
        use Role::*;
        let (name, (schema, schema_data), role) = match self {
            Topic::RawLidar => ("/raw/lidar", RAW, Input),
            Topic::RawLidarPosition => ("/raw/lidar_position", RAW, Input),
            Topic::RawImu => ("/raw/imu", RAW, Input),
            Topic::RawCan => ("/raw/can", RAW, Input),
            Topic::ImuTx => ("/imu/tx", RAW, Output),
            Topic::CanTx => ("/can/tx", CAN_FRAMES, Output),
            Topic::Imu => ("/imu", IMU, Output),
            Topic::ImuStatus => ("/imu/status", IMU_STATUS, Output),
            Topic::Cloud => ("/lidar/points", POINT_CLOUD2, Output),
            Topic::Drives => ("/drives", DRIVE_FEEDBACK, Output),
            Topic::Odom => ("/odom", ODOMETRY, Output),
            Topic::SlamPose => ("/slam/pose", POSE_STAMPED, Output),
            Topic::Tf => ("/tf", TF, Output),
            Topic::TfStatic => ("/tf_static", TF, Output),
            Topic::WheelCommand => ("/cmd/wheels", WHEEL_COMMAND, Output),
            Topic::Plan => ("/plan", MARKER_ARRAY, Output),
            Topic::PlannerPath => ("/planner/path", PATH, Output),
            Topic::Health => ("/diagnostics", DIAGNOSTICS, Output),
            Topic::Scheduler => ("/scheduler", SCHEDULER, Telemetry),
            Topic::FrameTiming => ("/executive/timing", FRAME_TIMING, Schedule),
            Topic::GroundTruth => ("/sim/ground_truth", POSE_STAMPED, Sim),
            // world -> map: where the simulated rover started.
            Topic::SimTf => ("/sim/tf", TF, Sim),
        };
        TopicInfo {
            topic: self,
            name,
            schema,
            schema_data,
            role,
        }
    }

    pub fn by_name(name: &str) -> Option<Topic> {
        Topic::ALL.into_iter().find(|t| t.info().name == name)
    }
}

type Schema = (&'static str, &'static str);

const RAW: Schema = ("speleo_msgs/msg/RawInput", schemas::RAW_INPUT);
const FRAME_TIMING: Schema = ("speleo_msgs/msg/FrameTiming", schemas::FRAME_TIMING);
const CAN_FRAMES: Schema = ("speleo_msgs/msg/CanFrames", schemas::CAN_FRAMES);
const IMU: Schema = ("sensor_msgs/msg/Imu", schemas::IMU);
const IMU_STATUS: Schema = ("speleo_msgs/msg/ImuStatus", schemas::IMU_STATUS);
const POINT_CLOUD2: Schema = ("sensor_msgs/msg/PointCloud2", schemas::POINT_CLOUD2);
const DRIVE_FEEDBACK: Schema = ("speleo_msgs/msg/DriveFeedback", schemas::DRIVE_FEEDBACK);
const ODOMETRY: Schema = ("nav_msgs/msg/Odometry", schemas::ODOMETRY);
const POSE_STAMPED: Schema = ("geometry_msgs/msg/PoseStamped", schemas::POSE_STAMPED);
const TF: Schema = ("tf2_msgs/msg/TFMessage", schemas::TF_MESSAGE);
const WHEEL_COMMAND: Schema = ("speleo_msgs/msg/WheelCommand", schemas::WHEEL_COMMAND);
const MARKER_ARRAY: Schema = ("visualization_msgs/msg/MarkerArray", schemas::MARKER_ARRAY);
const PATH: Schema = ("nav_msgs/msg/Path", schemas::PATH);
const DIAGNOSTICS: Schema = (
    "diagnostic_msgs/msg/DiagnosticArray",
    schemas::DIAGNOSTIC_ARRAY,
);
const SCHEDULER: Schema = (
    "speleo_msgs/msg/SchedulerTelemetry",
    schemas::SCHEDULER_TELEMETRY,
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_schema_parses_and_ids_round_trip() {
        for t in Topic::ALL {
            let i = t.info();
            super::super::msg_def::MessageDefs::parse(i.schema, i.schema_data)
                .unwrap_or_else(|e| panic!("{}: {e}", i.name));
            assert_eq!(Topic::from_channel_id(t.channel_id()), Some(t));
            assert_eq!(Topic::by_name(i.name), Some(t));
        }
    }
}
