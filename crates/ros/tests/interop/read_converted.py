"""Decodes every message of an MCAP written by `pmon convert --format mcap` with the Python `mcap` reader and
`mcap-ros2-support` (from the schemas pmon embedded), and prints a JSON summary the Rust test compares with
the recording it came from. Usage: read_converted.py FILE.mcap
"""
import json
import struct
import sys
from collections import Counter

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

counts, frames = Counter(), []
with open(sys.argv[1], "rb") as f:
    for schema, channel, message, msg in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
        counts[channel.topic] += 1
        if schema.name == "sensor_msgs/msg/PointCloud2":
            assert [x.name for x in msg.fields][:3] == ["x", "y", "z"] and msg.point_step == 16
            first = struct.unpack_from("<fff", bytes(msg.data), 0) if msg.width else None
            frames.append({"points": msg.width * msg.height, "first_point": first})
        elif schema.name == "autoware_perception_msgs/msg/TrackedObjects":
            ids = [int.from_bytes(bytes(o.object_id.uuid[:8]), "little") for o in msg.objects]
            xs = [o.kinematics.pose_with_covariance.pose.position.x for o in msg.objects]
            frames.append({"stamp": msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, "ids": ids, "xs": xs})
        elif schema.name == "tf2_msgs/msg/TFMessage":
            t = msg.transforms[0]
            assert t.header.frame_id == "base_link" and t.child_frame_id == "lidar"
print(json.dumps({"counts": counts, "frames": frames}))
