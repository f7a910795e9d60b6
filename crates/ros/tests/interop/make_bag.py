"""Writes a rosbag2 MCAP with Autoware messages using the pure-Python `rosbags` library (independent of pmon).

Scene (ego frame base_link; the ego stands at (100, 50) in map, yaw 0, from /localization/kinematic_state):
  - object A (car, UUID 1..): at ego (10, 0), 4 x 2 m, with LiDAR returns on it          -> consistent
  - object B (car, UUID 2..): at ego (20, 6), 4 x 2 m, no returns, ground visible around  -> ghost
  - returns at ego (15, -8), 1.5 x 1.5 m, no object                                     -> a missed object
  - the lidar frame is 2 m above base_link (from /tf_static): the cloud's z are shifted.
Three object lists (TrackedObjects in map) at t = 1.0, 1.1 and 1.3 s; clouds at 1.0 and 1.1 s and 1.6 s:
the list at 1.3 s has no cloud (reported unpaired), the cloud at 1.6 s no list (reported unpaired).
Usage: make_bag.py OUT_DIR [MODE] where MODE changes one thing (docs/ros2.md, "bad input"):
  --malformed   the second cloud's CDR is cut in half
  --empty-cloud the first cloud has no points
  --no-tf       no /tf_static: the transform base_link <- lidar is missing
  --time-jump   the third object list is stamped 0.5 s (time goes backwards)
  --detected    DetectedObjects (no UUIDs, no covariance) on /perception/object_recognition/detection/objects
"""
import math
import struct
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

HERE = Path(__file__).parent
ts = get_typestore(Stores.ROS2_HUMBLE)
types = {}
for f in sorted((HERE.parent.parent / "msg" / "autoware_perception_msgs").glob("*.msg")):
    types.update(get_types_from_msg(f.read_text(), f"autoware_perception_msgs/msg/{f.stem}"))
ts.register(types)
T = ts.types
Time = T["builtin_interfaces/msg/Time"]
Header = T["std_msgs/msg/Header"]
G = "geometry_msgs/msg/"


def stamp(t):
    return Time(sec=int(t), nanosec=int(round((t - int(t)) * 1e9)))


def quat(yaw):
    return T[G + "Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def vec(x, y, z):
    return T[G + "Vector3"](x=x, y=y, z=z)


EGO = (100.0, 50.0)
LIDAR_Z = 2.0


def box_points(cx, cy, l, w, step=0.1):
    pts = []
    for x in np.arange(cx - l / 2, cx + l / 2 + 1e-6, step):
        for y in np.arange(cy - w / 2, cy + w / 2 + 1e-6, step):
            for z in (0.5, 1.0, 1.5):
                pts.append((x, y, z))
    return pts


def cloud(t, empty=False):
    pts = []
    # Ground returns every 0.5 m out to 35 m: they make the regions visible (no obstacle in front of them).
    for x in np.arange(-35, 35.01, 0.5):
        for y in np.arange(-35, 35.01, 0.5):
            if x * x + y * y <= 35 * 35:
                pts.append((x, y, 0.02))
    pts += box_points(10.0, 0.0, 3.6, 1.6)  # object A
    pts += box_points(15.0, -8.0, 1.5, 1.5)  # nobody's
    if empty:
        pts = []
    # Autoware-like layout: x, y, z float32, intensity uint8 at 12, return_type uint8 at 13, channel uint16 at 14.
    data = bytearray()
    for (x, y, z) in pts:
        data += struct.pack("<fffBBH", x, y, z - LIDAR_Z, 100, 1, 7)
    PF = T["sensor_msgs/msg/PointField"]
    fields = [PF(name="x", offset=0, datatype=7, count=1), PF(name="y", offset=4, datatype=7, count=1),
              PF(name="z", offset=8, datatype=7, count=1), PF(name="intensity", offset=12, datatype=2, count=1),
              PF(name="return_type", offset=13, datatype=2, count=1), PF(name="channel", offset=14, datatype=4, count=1)]
    return T["sensor_msgs/msg/PointCloud2"](
        header=Header(stamp=stamp(t), frame_id="lidar"), height=1, width=len(pts), fields=fields,
        is_bigendian=False, point_step=16, row_step=16 * len(pts), data=np.frombuffer(bytes(data), dtype=np.uint8),
        is_dense=True)


def cov(sx, sy, syaw):
    c = np.zeros(36)
    c[0], c[7], c[14], c[35] = sx * sx, sy * sy, 0.01, syaw * syaw
    return c


def tracked(uuid_byte, ex, ey, label, speed):
    A = "autoware_perception_msgs/msg/"
    pose = T[G + "Pose"](position=T[G + "Point"](x=EGO[0] + ex, y=EGO[1] + ey, z=0.75), orientation=quat(0.0))
    twist = T[G + "Twist"](linear=vec(speed, 0.0, 0.0), angular=vec(0.0, 0.0, 0.0))
    tcov = np.zeros(36)
    tcov[0] = 0.04
    kin = T[A + "TrackedObjectKinematics"](
        pose_with_covariance=T[G + "PoseWithCovariance"](pose=pose, covariance=cov(0.1, 0.1, 0.05)),
        twist_with_covariance=T[G + "TwistWithCovariance"](twist=twist, covariance=tcov),
        acceleration_with_covariance=T[G + "AccelWithCovariance"](
            accel=T[G + "Accel"](linear=vec(0.0, 0.0, 0.0), angular=vec(0.0, 0.0, 0.0)), covariance=np.zeros(36)),
        orientation_availability=2, is_stationary=speed == 0.0)
    shape = T[A + "Shape"](type=0, footprint=T[G + "Polygon"](points=[]), dimensions=vec(4.0, 2.0, 1.5))
    uuid = np.zeros(16, dtype=np.uint8)
    uuid[0] = uuid_byte
    uuid[15] = 0xAB
    return T[A + "TrackedObject"](
        object_id=T["unique_identifier_msgs/msg/UUID"](uuid=uuid), existence_probability=0.9,
        classification=[T[A + "ObjectClassification"](label=label, probability=0.9)], kinematics=kin, shape=shape)


def detected(ex, ey, label):
    A = "autoware_perception_msgs/msg/"
    pose = T[G + "Pose"](position=T[G + "Point"](x=EGO[0] + ex, y=EGO[1] + ey, z=0.75), orientation=quat(0.0))
    twist = T[G + "Twist"](linear=vec(0.0, 0.0, 0.0), angular=vec(0.0, 0.0, 0.0))
    kin = T[A + "DetectedObjectKinematics"](
        pose_with_covariance=T[G + "PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        has_position_covariance=False, orientation_availability=1,
        twist_with_covariance=T[G + "TwistWithCovariance"](twist=twist, covariance=np.zeros(36)),
        has_twist=False, has_twist_covariance=False)
    # A polygon footprint (object frame) instead of a box: 4 x 2 m.
    P32 = T[G + "Point32"]
    foot = [P32(x=-2.0, y=-1.0, z=0.0), P32(x=2.0, y=-1.0, z=0.0), P32(x=2.0, y=1.0, z=0.0), P32(x=-2.0, y=1.0, z=0.0)]
    shape = T[A + "Shape"](type=2, footprint=T[G + "Polygon"](points=foot), dimensions=vec(0.0, 0.0, 1.5))
    return T[A + "DetectedObject"](
        existence_probability=0.9, classification=[T[A + "ObjectClassification"](label=label, probability=0.9)],
        kinematics=kin, shape=shape)


def detected_objects(t):
    return T["autoware_perception_msgs/msg/DetectedObjects"](
        header=Header(stamp=stamp(t), frame_id="map"), objects=[detected(10.0, 0.0, 1), detected(20.0, 6.0, 1)])


def objects(t):
    return T["autoware_perception_msgs/msg/TrackedObjects"](
        header=Header(stamp=stamp(t), frame_id="map"),
        objects=[tracked(1, 10.0, 0.0, 1, 0.0), tracked(2, 20.0, 6.0, 1, 0.0)])


def odometry(t):
    pose = T[G + "Pose"](position=T[G + "Point"](x=EGO[0], y=EGO[1], z=0.0), orientation=quat(0.0))
    return T["nav_msgs/msg/Odometry"](
        header=Header(stamp=stamp(t), frame_id="map"), child_frame_id="base_link",
        pose=T[G + "PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=T[G + "TwistWithCovariance"](
            twist=T[G + "Twist"](linear=vec(0.0, 0.0, 0.0), angular=vec(0.0, 0.0, 0.0)), covariance=np.zeros(36)))


def tf_static():
    tr = T[G + "TransformStamped"](
        header=Header(stamp=stamp(0.0), frame_id="base_link"), child_frame_id="lidar",
        transform=T[G + "Transform"](translation=vec(0.0, 0.0, LIDAR_Z), rotation=quat(0.0)))
    return T["tf2_msgs/msg/TFMessage"](transforms=[tr])


def main():
    out = Path(sys.argv[1])
    malformed = "--malformed" in sys.argv
    empty = "--empty-cloud" in sys.argv
    no_tf = "--no-tf" in sys.argv
    list_times = (1.0, 1.1, 0.5 if "--time-jump" in sys.argv else 1.3)
    with Writer(out, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        c_tf = w.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=ts)
        c_odo = w.add_connection("/localization/kinematic_state", "nav_msgs/msg/Odometry", typestore=ts)
        c_pc = w.add_connection("/sensing/lidar/concatenated/pointcloud", "sensor_msgs/msg/PointCloud2", typestore=ts)
        is_det = "--detected" in sys.argv
        obj_type = "autoware_perception_msgs/msg/" + ("DetectedObjects" if is_det else "TrackedObjects")
        obj_topic = "/perception/object_recognition/" + ("detection" if is_det else "tracking") + "/objects"
        c_obj = w.add_connection(obj_topic, obj_type, typestore=ts)
        ns = lambda t: int(round(t * 1e9))
        if not no_tf:
            w.write(c_tf, ns(0.9), ts.serialize_cdr(tf_static(), "tf2_msgs/msg/TFMessage"))
        for k in range(-25, 40):
            t = 0.9 + 0.02 * k
            w.write(c_odo, ns(t), ts.serialize_cdr(odometry(t), "nav_msgs/msg/Odometry"))
        for i, t in enumerate((1.0, 1.1, 1.6)):
            raw = ts.serialize_cdr(cloud(t, empty and i == 0), "sensor_msgs/msg/PointCloud2")
            if malformed and i == 1:
                raw = raw[: len(raw) // 2]
            w.write(c_pc, ns(t) + 1000, raw)
        for t in list_times:
            msg = detected_objects(t) if is_det else objects(t)
            w.write(c_obj, ns(t) + 2000, ts.serialize_cdr(msg, obj_type))
    print(next(out.glob("*.mcap")))


if __name__ == "__main__":
    main()
