//! ROS 2 message types as serde structs, field for field in the upstream `.msg` order (CDR is positional).
//!
//! Layouts are taken from the upstream definitions:
//! - `ros2/common_interfaces` commit `c0c0bc57f958eb54a142446f0c2a475754367eee` (sensor_msgs 5.4.2):
//!   `std_msgs`, `geometry_msgs`, `sensor_msgs`, `nav_msgs`, `diagnostic_msgs`;
//! - `ros2/geometry2` `tf2_msgs/TFMessage` (`geometry_msgs/TransformStamped[] transforms`);
//! - `ros2/unique_identifier_msgs` `UUID` (`uint8[16] uuid`);
//! - `autowarefoundation/autoware_msgs` commit `7025d8f7df0ead43037d86f8a4ffda8b397d0293`
//!   (autoware_perception_msgs 1.12.0);
//! - pmon's own `pmon_msgs` in `crates/ros/msg/`.

use serde::{Deserialize, Serialize};
use serde_big_array::BigArray;

/// `builtin_interfaces/Time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, `< 1e9`.
    pub nanosec: u32,
}

impl Time {
    /// Seconds as `f64`.
    #[must_use]
    pub fn as_secs_f64(self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
    /// Nanoseconds since the epoch (negative times clamp to 0), as MCAP log times.
    #[must_use]
    pub fn as_nanos(self) -> u64 {
        u64::try_from(i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)).unwrap_or(0)
    }
    /// From nanoseconds since the epoch (saturating at `i32::MAX` seconds).
    #[must_use]
    pub fn from_nanos(ns: u64) -> Self {
        let sec = i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX);
        Self { sec, nanosec: (ns % 1_000_000_000) as u32 }
    }
}

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Acquisition time.
    pub stamp: Time,
    /// Coordinate frame.
    pub frame_id: String,
}

/// `geometry_msgs/Point` (and `Vector3`: the same layout).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/Point32`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point32 {
    /// x.
    pub x: f32,
    /// y.
    pub y: f32,
    /// z.
    pub z: f32,
}

/// `geometry_msgs/Quaternion`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }
    }
}

/// `geometry_msgs/Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position (`geometry_msgs/Point`).
    pub position: Vector3,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/Twist` (and `Accel`: the same layout).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity.
    pub linear: Vector3,
    /// Angular velocity.
    pub angular: Vector3,
}

/// `geometry_msgs/PoseWithCovariance`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// Pose.
    pub pose: Pose,
    /// Row-major 6x6 covariance of (x, y, z, rot x, rot y, rot z).
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

/// `geometry_msgs/TwistWithCovariance` (and `AccelWithCovariance`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// Twist.
    pub twist: Twist,
    /// Row-major 6x6 covariance.
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

impl Default for PoseWithCovariance {
    fn default() -> Self {
        Self { pose: Pose::default(), covariance: [0.0; 36] }
    }
}

impl Default for TwistWithCovariance {
    fn default() -> Self {
        Self { twist: Twist::default(), covariance: [0.0; 36] }
    }
}

/// `geometry_msgs/Transform`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// `parent_from_child`.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// Transforms.
    pub transforms: Vec<TransformStamped>,
}

/// `nav_msgs/Odometry`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp and the pose's frame (`map`).
    pub header: Header,
    /// The body frame (`base_link`).
    pub child_frame_id: String,
    /// Pose of the child in the header frame.
    pub pose: PoseWithCovariance,
    /// Twist in the child frame.
    pub twist: TwistWithCovariance,
}

/// `sensor_msgs/PointField`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointField {
    /// Field name (`x`, `y`, `z`, `intensity`, ...).
    pub name: String,
    /// Byte offset within a point.
    pub offset: u32,
    /// `INT8 = 1` ... `FLOAT64 = 8`.
    pub datatype: u8,
    /// Elements in the field.
    pub count: u32,
}

/// `sensor_msgs/PointCloud2`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// Stamp and the sensor frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// Field layout.
    pub fields: Vec<PointField>,
    /// Byte order of `data`.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// `row_step * height` bytes.
    pub data: Vec<u8>,
    /// No invalid points.
    pub is_dense: bool,
}

/// Only the header of a `sensor_msgs/PointCloud2` (CDR is positional: the header comes first), to pair
/// clouds without decoding their points.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HeaderOnly {
    /// The header.
    pub header: Header,
}

/// `unique_identifier_msgs/UUID`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Uuid {
    /// 16 bytes.
    pub uuid: [u8; 16],
}

/// `autoware_perception_msgs/ObjectClassification`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectClassification {
    /// `UNKNOWN = 0, CAR, TRUCK, BUS, TRAILER, MOTORCYCLE, BICYCLE, PEDESTRIAN, ANIMAL, HAZARD, OVER_DRIVABLE,
    /// UNDER_DRIVABLE = 11`.
    pub label: u8,
    /// Probability.
    pub probability: f32,
}

/// `autoware_perception_msgs/Shape`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Shape {
    /// `BOUNDING_BOX = 0`, `CYLINDER = 1`, `POLYGON = 2`.
    #[serde(rename = "type")]
    pub shape_type: u8,
    /// Base polygon (`geometry_msgs/Polygon`), object frame.
    pub footprint: Vec<Point32>,
    /// Box: x = length, y = width, z = height; cylinder: x = y = diameter.
    pub dimensions: Vector3,
}

/// `autoware_perception_msgs/DetectedObjectKinematics`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DetectedObjectKinematics {
    /// Pose.
    pub pose_with_covariance: PoseWithCovariance,
    /// Whether the pose covariance is filled.
    pub has_position_covariance: bool,
    /// `UNAVAILABLE = 0`, `SIGN_UNKNOWN = 1`, `AVAILABLE = 2`.
    pub orientation_availability: u8,
    /// Twist in the object frame.
    pub twist_with_covariance: TwistWithCovariance,
    /// Whether the twist is filled.
    pub has_twist: bool,
    /// Whether the twist covariance is filled.
    pub has_twist_covariance: bool,
}

/// `autoware_perception_msgs/DetectedObject`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DetectedObject {
    /// Existence probability.
    pub existence_probability: f32,
    /// Class hypotheses.
    pub classification: Vec<ObjectClassification>,
    /// Kinematics.
    pub kinematics: DetectedObjectKinematics,
    /// Shape.
    pub shape: Shape,
}

/// `autoware_perception_msgs/DetectedObjects`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DetectedObjects {
    /// Stamp and frame of the poses.
    pub header: Header,
    /// Objects.
    pub objects: Vec<DetectedObject>,
}

/// `autoware_perception_msgs/TrackedObjectKinematics`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackedObjectKinematics {
    /// Pose.
    pub pose_with_covariance: PoseWithCovariance,
    /// Twist in the object frame.
    pub twist_with_covariance: TwistWithCovariance,
    /// Acceleration (`geometry_msgs/AccelWithCovariance`).
    pub acceleration_with_covariance: TwistWithCovariance,
    /// `UNAVAILABLE = 0`, `SIGN_UNKNOWN = 1`, `AVAILABLE = 2`.
    pub orientation_availability: u8,
    /// Whether the object stands still.
    pub is_stationary: bool,
}

/// `autoware_perception_msgs/TrackedObject`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackedObject {
    /// Track UUID.
    pub object_id: Uuid,
    /// Existence probability.
    pub existence_probability: f32,
    /// Class hypotheses.
    pub classification: Vec<ObjectClassification>,
    /// Kinematics.
    pub kinematics: TrackedObjectKinematics,
    /// Shape.
    pub shape: Shape,
}

/// `autoware_perception_msgs/TrackedObjects`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackedObjects {
    /// Stamp and frame of the poses.
    pub header: Header,
    /// Objects.
    pub objects: Vec<TrackedObject>,
}

/// `diagnostic_msgs/KeyValue`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct KeyValue {
    /// Key.
    pub key: String,
    /// Value.
    pub value: String,
}

/// `diagnostic_msgs/DiagnosticStatus`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// `OK = 0`, `WARN = 1`, `ERROR = 2`, `STALE = 3`.
    pub level: u8,
    /// Component name.
    pub name: String,
    /// Message.
    pub message: String,
    /// Hardware id.
    pub hardware_id: String,
    /// Key-values.
    pub values: Vec<KeyValue>,
}

/// `diagnostic_msgs/DiagnosticArray`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Stamp.
    pub header: Header,
    /// Statuses.
    pub status: Vec<DiagnosticStatus>,
}

/// `pmon_msgs/ObjectVerdict` (`crates/ros/msg/ObjectVerdict.msg`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectVerdict {
    /// UUID of a tracked object (zero for detections).
    pub object_id: Uuid,
    /// pmon's id.
    pub id: u64,
    /// `CONSISTENT = 0`, `GHOST = 1`, `POSITION_ERROR = 2`, `IMPLAUSIBLE_MOTION = 3`, `NOT_MONITORED = 4`.
    pub verdict: u8,
    /// The verdict's name.
    pub verdict_name: String,
    /// Not monitored: why; implausible motion: the conditions; position error: which test found it
    /// (`displaced_evidence`, `seen_through`, ...: `pmon_monitor::PositionCause`).
    pub reason: String,
    /// Centre, ego frame, metres.
    pub x_m: f32,
    /// Centre, ego frame, metres.
    pub y_m: f32,
    /// Largest occupancy probability in the region.
    pub eta: f32,
    /// Visible share of the region.
    pub visible_fraction: f32,
    /// Offset of the evidence, ego frame, metres.
    pub offset_m: [f32; 2],
}

/// `pmon_msgs/MissedObject`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MissedObject {
    /// Centroid, ego frame, metres.
    pub centroid_m: [f32; 2],
    /// Bounds `[min_x, min_y, max_x, max_y]`, ego frame, metres.
    pub bounds_m: [f32; 4],
    /// Cells.
    pub cells: u32,
}

/// `pmon_msgs/FrameVerdicts` (`crates/ros/msg/FrameVerdicts.msg`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameVerdicts {
    /// Stamp and frame of the checked object list.
    pub header: Header,
    /// Stamp of the paired cloud.
    pub cloud_stamp: Time,
    /// Whether a cloud was paired.
    pub cloud_paired: bool,
    /// Empty when the sensor checks ran, else why not.
    pub sensor_status: String,
    /// Points in the sweep.
    pub points_total: u32,
    /// Points in the height band.
    pub points_in_band: u32,
    /// Wall time of the check, seconds.
    pub processing_time_s: f64,
    /// One per object, in list order.
    pub objects: Vec<ObjectVerdict>,
    /// Missed objects.
    pub missed: Vec<MissedObject>,
}

/// ROS 2 type names and full `ros2msg` schema texts (the type, then each dependency after a `===` line, as
/// rosbag2 writes them into MCAP) of the messages pmon writes.
pub mod schema {
    const SEP: &str = "================================================================================\nMSG: ";
    const HEADER: &str = "builtin_interfaces/Time stamp\nstring frame_id\n";
    const TIME: &str = "int32 sec\nuint32 nanosec\n";

    /// `pmon_msgs/msg/FrameVerdicts`.
    pub const FRAME_VERDICTS: &str = "pmon_msgs/msg/FrameVerdicts";
    /// `diagnostic_msgs/msg/DiagnosticArray`.
    pub const DIAGNOSTIC_ARRAY: &str = "diagnostic_msgs/msg/DiagnosticArray";

    /// The schema text of `pmon_msgs/msg/FrameVerdicts` with its dependencies.
    #[must_use]
    pub fn frame_verdicts() -> String {
        format!(
            "{}\n{SEP}std_msgs/Header\n{HEADER}{SEP}builtin_interfaces/Time\n{TIME}{SEP}pmon_msgs/ObjectVerdict\n{}\n\
             {SEP}unique_identifier_msgs/UUID\nuint8[16] uuid\n{SEP}pmon_msgs/MissedObject\n{}",
            include_str!("../msg/FrameVerdicts.msg"),
            include_str!("../msg/ObjectVerdict.msg"),
            include_str!("../msg/MissedObject.msg"),
        )
    }

    /// The schema text of `diagnostic_msgs/msg/DiagnosticArray` with its dependencies.
    #[must_use]
    pub fn diagnostic_array() -> String {
        format!(
            "std_msgs/Header header\nDiagnosticStatus[] status\n{SEP}std_msgs/Header\n{HEADER}\
             {SEP}builtin_interfaces/Time\n{TIME}{SEP}diagnostic_msgs/DiagnosticStatus\n\
             byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\nstring message\n\
             string hardware_id\nKeyValue[] values\n{SEP}diagnostic_msgs/KeyValue\nstring key\nstring value\n"
        )
    }
}
