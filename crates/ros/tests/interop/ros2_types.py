"""ROS 2 message types for Cyclone DDS (PyPI `cyclonedds`), written here from the upstream `.msg` files
independently of pmon's Rust types: ros2/common_interfaces (sensor_msgs 5.4.2: std, geometry, nav, sensor,
diagnostic msgs), tf2_msgs and unique_identifier_msgs as in Humble, autoware_perception_msgs 1.12.0
(crates/ros/msg/autoware_perception_msgs), and pmon_msgs (crates/ros/msg). DDS type names follow ROS 2's
`pkg::msg::dds_::Type_` mangling; CDR is Cyclone's own (XCDR1, as ROS 2 uses).
"""
from dataclasses import dataclass

import cyclonedds.idl.types as t
from cyclonedds.idl import IdlStruct


def _name(pkg, ty):
    return f"{pkg}::msg::dds_::{ty}_"


@dataclass
class Time(IdlStruct, typename=_name("builtin_interfaces", "Time")):
    sec: t.int32
    nanosec: t.uint32


@dataclass
class Header(IdlStruct, typename=_name("std_msgs", "Header")):
    stamp: Time
    frame_id: str


@dataclass
class Point(IdlStruct, typename=_name("geometry_msgs", "Point")):
    x: t.float64
    y: t.float64
    z: t.float64


@dataclass
class Vector3(IdlStruct, typename=_name("geometry_msgs", "Vector3")):
    x: t.float64
    y: t.float64
    z: t.float64


@dataclass
class Point32(IdlStruct, typename=_name("geometry_msgs", "Point32")):
    x: t.float32
    y: t.float32
    z: t.float32


@dataclass
class Polygon(IdlStruct, typename=_name("geometry_msgs", "Polygon")):
    points: t.sequence[Point32]


@dataclass
class Quaternion(IdlStruct, typename=_name("geometry_msgs", "Quaternion")):
    x: t.float64
    y: t.float64
    z: t.float64
    w: t.float64


@dataclass
class Pose(IdlStruct, typename=_name("geometry_msgs", "Pose")):
    position: Point
    orientation: Quaternion


@dataclass
class PoseWithCovariance(IdlStruct, typename=_name("geometry_msgs", "PoseWithCovariance")):
    pose: Pose
    covariance: t.array[t.float64, 36]


@dataclass
class Twist(IdlStruct, typename=_name("geometry_msgs", "Twist")):
    linear: Vector3
    angular: Vector3


@dataclass
class TwistWithCovariance(IdlStruct, typename=_name("geometry_msgs", "TwistWithCovariance")):
    twist: Twist
    covariance: t.array[t.float64, 36]


@dataclass
class Accel(IdlStruct, typename=_name("geometry_msgs", "Accel")):
    linear: Vector3
    angular: Vector3


@dataclass
class AccelWithCovariance(IdlStruct, typename=_name("geometry_msgs", "AccelWithCovariance")):
    accel: Accel
    covariance: t.array[t.float64, 36]


@dataclass
class Transform(IdlStruct, typename=_name("geometry_msgs", "Transform")):
    translation: Vector3
    rotation: Quaternion


@dataclass
class TransformStamped(IdlStruct, typename=_name("geometry_msgs", "TransformStamped")):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
class TFMessage(IdlStruct, typename=_name("tf2_msgs", "TFMessage")):
    transforms: t.sequence[TransformStamped]


@dataclass
class Odometry(IdlStruct, typename=_name("nav_msgs", "Odometry")):
    header: Header
    child_frame_id: str
    pose: PoseWithCovariance
    twist: TwistWithCovariance


@dataclass
class PointField(IdlStruct, typename=_name("sensor_msgs", "PointField")):
    name: str
    offset: t.uint32
    datatype: t.uint8
    count: t.uint32


@dataclass
class PointCloud2(IdlStruct, typename=_name("sensor_msgs", "PointCloud2")):
    header: Header
    height: t.uint32
    width: t.uint32
    fields: t.sequence[PointField]
    is_bigendian: bool
    point_step: t.uint32
    row_step: t.uint32
    data: t.sequence[t.uint8]
    is_dense: bool


@dataclass
class UUID(IdlStruct, typename="unique_identifier_msgs::msg::dds_::UUID_"):
    uuid: t.array[t.uint8, 16]


AW = "autoware_perception_msgs"


@dataclass
class ObjectClassification(IdlStruct, typename=_name(AW, "ObjectClassification")):
    label: t.uint8
    probability: t.float32


@dataclass
class Shape(IdlStruct, typename=_name(AW, "Shape")):
    type: t.uint8
    footprint: Polygon
    dimensions: Vector3


@dataclass
class DetectedObjectKinematics(IdlStruct, typename=_name(AW, "DetectedObjectKinematics")):
    pose_with_covariance: PoseWithCovariance
    has_position_covariance: bool
    orientation_availability: t.uint8
    twist_with_covariance: TwistWithCovariance
    has_twist: bool
    has_twist_covariance: bool


@dataclass
class DetectedObject(IdlStruct, typename=_name(AW, "DetectedObject")):
    existence_probability: t.float32
    classification: t.sequence[ObjectClassification]
    kinematics: DetectedObjectKinematics
    shape: Shape


@dataclass
class DetectedObjects(IdlStruct, typename=_name(AW, "DetectedObjects")):
    header: Header
    objects: t.sequence[DetectedObject]


@dataclass
class TrackedObjectKinematics(IdlStruct, typename=_name(AW, "TrackedObjectKinematics")):
    pose_with_covariance: PoseWithCovariance
    twist_with_covariance: TwistWithCovariance
    acceleration_with_covariance: AccelWithCovariance
    orientation_availability: t.uint8
    is_stationary: bool


@dataclass
class TrackedObject(IdlStruct, typename=_name(AW, "TrackedObject")):
    object_id: UUID
    existence_probability: t.float32
    classification: t.sequence[ObjectClassification]
    kinematics: TrackedObjectKinematics
    shape: Shape


@dataclass
class TrackedObjects(IdlStruct, typename=_name(AW, "TrackedObjects")):
    header: Header
    objects: t.sequence[TrackedObject]


@dataclass
class KeyValue(IdlStruct, typename=_name("diagnostic_msgs", "KeyValue")):
    key: str
    value: str


@dataclass
class DiagnosticStatus(IdlStruct, typename=_name("diagnostic_msgs", "DiagnosticStatus")):
    level: t.uint8  # `byte` in the .msg: an octet in DDS
    name: str
    message: str
    hardware_id: str
    values: t.sequence[KeyValue]


@dataclass
class DiagnosticArray(IdlStruct, typename=_name("diagnostic_msgs", "DiagnosticArray")):
    header: Header
    status: t.sequence[DiagnosticStatus]


@dataclass
class ObjectVerdict(IdlStruct, typename=_name("pmon_msgs", "ObjectVerdict")):
    object_id: UUID
    id: t.uint64
    verdict: t.uint8
    verdict_name: str
    reason: str
    x_m: t.float32
    y_m: t.float32
    eta: t.float32
    visible_fraction: t.float32
    offset_m: t.array[t.float32, 2]


@dataclass
class MissedObject(IdlStruct, typename=_name("pmon_msgs", "MissedObject")):
    centroid_m: t.array[t.float32, 2]
    bounds_m: t.array[t.float32, 4]
    cells: t.uint32


@dataclass
class FrameVerdicts(IdlStruct, typename=_name("pmon_msgs", "FrameVerdicts")):
    header: Header
    cloud_stamp: Time
    cloud_paired: bool
    sensor_status: str
    points_total: t.uint32
    points_in_band: t.uint32
    processing_time_s: t.float64
    objects: t.sequence[ObjectVerdict]
    missed: t.sequence[MissedObject]


# ROS 2 type name (as in an MCAP schema) -> class.
BY_ROS_NAME = {
    "sensor_msgs/msg/PointCloud2": PointCloud2,
    f"{AW}/msg/TrackedObjects": TrackedObjects,
    f"{AW}/msg/DetectedObjects": DetectedObjects,
    "nav_msgs/msg/Odometry": Odometry,
    "tf2_msgs/msg/TFMessage": TFMessage,
}


@dataclass
class PointCloud2HeaderOnly(IdlStruct, typename=_name("sensor_msgs", "PointCloud2")):
    """A peer with a wrong definition of PointCloud2 (only the header): what it sends does not decode as a
    PointCloud2 at the receiver. Used to send a malformed sample over DDS, which Cyclone refuses to do with raw
    bytes that do not match the type."""
    header: Header
