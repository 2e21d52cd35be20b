//! The ROS 2 message definitions (`ros2msg`) of every recorded type, each
//! followed by the definitions it depends on, as rosbag2 writes them into
//! MCAP schemas. Standard types follow ROS 2 Jazzy; `speleo_msgs` types are
//! read from the interface package in `ros2/speleo_msgs`, so the recording
//! and a ROS 2 workspace build the same definitions.

macro_rules! dep {
    ($name:literal, $body:expr) => {
        concat!(
            "================================================================================\n",
            "MSG: ",
            $name,
            "\n",
            $body
        )
    };
}

macro_rules! time {
    () => {
        dep!("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n")
    };
}
macro_rules! duration {
    () => {
        dep!("builtin_interfaces/Duration", "int32 sec\nuint32 nanosec\n")
    };
}
macro_rules! header {
    () => {
        dep!(
            "std_msgs/Header",
            "builtin_interfaces/Time stamp\nstring frame_id\n"
        )
    };
}
macro_rules! color_rgba {
    () => {
        dep!(
            "std_msgs/ColorRGBA",
            "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n"
        )
    };
}
macro_rules! vector3 {
    () => {
        dep!("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n")
    };
}
macro_rules! point {
    () => {
        dep!("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n")
    };
}
macro_rules! quaternion {
    () => {
        dep!(
            "geometry_msgs/Quaternion",
            "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"
        )
    };
}
macro_rules! pose {
    () => {
        dep!(
            "geometry_msgs/Pose",
            "Point position\nQuaternion orientation\n"
        )
    };
}
macro_rules! pose_stamped {
    () => {
        dep!(
            "geometry_msgs/PoseStamped",
            "std_msgs/Header header\nPose pose\n"
        )
    };
}
macro_rules! speleo {
    ($name:literal) => {
        include_str!(concat!("../../../ros2/speleo_msgs/msg/", $name, ".msg"))
    };
}

/// `tf2_msgs/msg/TFMessage`.
pub const TF_MESSAGE: &str = concat!(
    "geometry_msgs/TransformStamped[] transforms\n",
    dep!(
        "geometry_msgs/TransformStamped",
        "std_msgs/Header header\nstring child_frame_id\nTransform transform\n"
    ),
    header!(),
    time!(),
    dep!(
        "geometry_msgs/Transform",
        "Vector3 translation\nQuaternion rotation\n"
    ),
    vector3!(),
    quaternion!(),
);

/// `nav_msgs/msg/Odometry`.
pub const ODOMETRY: &str = concat!(
    "std_msgs/Header header\n",
    "string child_frame_id\n",
    "geometry_msgs/PoseWithCovariance pose\n",
    "geometry_msgs/TwistWithCovariance twist\n",
    header!(),
    time!(),
    dep!(
        "geometry_msgs/PoseWithCovariance",
        "Pose pose\nfloat64[36] covariance\n"
    ),
    pose!(),
    point!(),
    quaternion!(),
    dep!(
        "geometry_msgs/TwistWithCovariance",
        "Twist twist\nfloat64[36] covariance\n"
    ),
    dep!("geometry_msgs/Twist", "Vector3 linear\nVector3 angular\n"),
    vector3!(),
);

/// `sensor_msgs/msg/Imu`.
pub const IMU: &str = concat!(
    "std_msgs/Header header\n",
    "geometry_msgs/Quaternion orientation\n",
    "float64[9] orientation_covariance\n",
    "geometry_msgs/Vector3 angular_velocity\n",
    "float64[9] angular_velocity_covariance\n",
    "geometry_msgs/Vector3 linear_acceleration\n",
    "float64[9] linear_acceleration_covariance\n",
    header!(),
    time!(),
    quaternion!(),
    vector3!(),
);

/// `geometry_msgs/msg/PoseStamped`.
pub const POSE_STAMPED: &str = concat!(
    "std_msgs/Header header\nPose pose\n",
    header!(),
    time!(),
    pose!(),
    point!(),
    quaternion!(),
);

/// `nav_msgs/msg/Path`.
pub const PATH: &str = concat!(
    "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n",
    header!(),
    time!(),
    pose_stamped!(),
    pose!(),
    point!(),
    quaternion!(),
);

/// `diagnostic_msgs/msg/DiagnosticArray`.
pub const DIAGNOSTIC_ARRAY: &str = concat!(
    "std_msgs/Header header\nDiagnosticStatus[] status\n",
    header!(),
    time!(),
    dep!(
        "diagnostic_msgs/DiagnosticStatus",
        "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\n\
         byte level\nstring name\nstring message\nstring hardware_id\nKeyValue[] values\n"
    ),
    dep!("diagnostic_msgs/KeyValue", "string key\nstring value\n"),
);

/// `visualization_msgs/msg/MarkerArray` (Jazzy's `Marker`, with textures
/// and embedded meshes).
pub const MARKER_ARRAY: &str = concat!(
    "Marker[] markers\n",
    dep!(
        "visualization_msgs/Marker",
        "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\n\
         int32 LINE_STRIP=4\nint32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\n\
         int32 POINTS=8\nint32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\n\
         int32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n\
         std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\n\
         geometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n\
         builtin_interfaces/Duration lifetime\nbool frame_locked\n\
         geometry_msgs/Point[] points\nstd_msgs/ColorRGBA[] colors\n\
         string texture_resource\nsensor_msgs/CompressedImage texture\nUVCoordinate[] uv_coordinates\n\
         string text\nstring mesh_resource\nMeshFile mesh_file\nbool mesh_use_embedded_materials\n"
    ),
    header!(),
    time!(),
    pose!(),
    point!(),
    quaternion!(),
    vector3!(),
    color_rgba!(),
    duration!(),
    dep!(
        "sensor_msgs/CompressedImage",
        "std_msgs/Header header\nstring format\nuint8[] data\n"
    ),
    dep!("visualization_msgs/UVCoordinate", "float32 u\nfloat32 v\n"),
    dep!("visualization_msgs/MeshFile", "string filename\nuint8[] data\n"),
);

/// `sensor_msgs/msg/PointCloud2`.
pub const POINT_CLOUD2: &str = concat!(
    "std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\n",
    "bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n",
    header!(),
    time!(),
    dep!(
        "sensor_msgs/PointField",
        "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\n\
         uint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\n\
         string name\nuint32 offset\nuint8 datatype\nuint32 count\n"
    ),
);

/// `speleo_msgs/msg/RawInput`.
pub const RAW_INPUT: &str = concat!(speleo!("RawInput"), time!());

/// `speleo_msgs/msg/FrameTiming`.
pub const FRAME_TIMING: &str = concat!(speleo!("FrameTiming"), time!());

/// `speleo_msgs/msg/CanFrames`.
pub const CAN_FRAMES: &str = concat!(
    speleo!("CanFrames"),
    header!(),
    time!(),
    dep!("speleo_msgs/CanFrame", speleo!("CanFrame")),
);

/// `speleo_msgs/msg/ImuStatus`.
pub const IMU_STATUS: &str = concat!(speleo!("ImuStatus"), header!(), time!());

/// `speleo_msgs/msg/DriveFeedback`.
pub const DRIVE_FEEDBACK: &str = concat!(
    speleo!("DriveFeedback"),
    header!(),
    time!(),
    dep!("speleo_msgs/WheelDrive", speleo!("WheelDrive")),
    dep!("speleo_msgs/DriveStop", speleo!("DriveStop")),
);

/// `speleo_msgs/msg/WheelCommand`.
pub const WHEEL_COMMAND: &str = concat!(speleo!("WheelCommand"), header!(), time!());

/// `speleo_msgs/msg/SchedulerTelemetry`.
pub const SCHEDULER_TELEMETRY: &str = concat!(
    speleo!("SchedulerTelemetry"),
    header!(),
    time!(),
    dep!("speleo_msgs/TaskStats", speleo!("TaskStats")),
);
