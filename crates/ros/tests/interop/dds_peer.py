"""An independent DDS peer for `pmon ros2` (Cyclone DDS from PyPI, not pmon's RustDDS): replays a rosbag2 MCAP
over DDS and records what pmon publishes.

Usage: dds_peer.py BAG.mcap OUT.json [--domain D] [--rate-hz R] [--timeout-s T] [--objects-topic TOPIC]

- Reads every message of the bag with the Python `mcap` reader and decodes its CDR with Cyclone's own
  deserializer into the types of ros2_types.py (written from the upstream .msg files, independent of pmon).
- Waits until pmon's readers have matched each of its writers (discovery), then publishes `/tf_static`
  (transient local) and the other messages in the bag's log-time order, one object list per 1/R s (the
  messages before an object list go out just before it: odometry, transforms, its cloud).
- Subscribes to `/pmon/verdicts` (pmon_msgs/FrameVerdicts) and `/diagnostics` (diagnostic_msgs/DiagnosticArray)
  and writes everything received to OUT.json, with the time from publishing each object list to receiving its
  verdicts (matched by stamp).
Exit status 0 when one verdict per object list arrived before the timeout, 1 otherwise.
"""
import argparse
import json
import sys
import time
from dataclasses import asdict

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from mcap.reader import make_reader

import ros2_types as R

ap = argparse.ArgumentParser()
ap.add_argument("bag")
ap.add_argument("out")
ap.add_argument("--rate-hz", type=float, default=10.0)
ap.add_argument("--timeout-s", type=float, default=60.0)
ap.add_argument("--domain", type=int, default=0)
ap.add_argument("--objects-topic", default="/perception/object_recognition/tracking/objects")
ap.add_argument("--cloud-best-effort", action="store_true", help="publish clouds best effort (sensor-data QoS)")
args = ap.parse_args()

reliable = Qos(Policy.Reliability.Reliable(duration(seconds=2)), Policy.History.KeepLast(10),
               Policy.Durability.Volatile)
latched = Qos(Policy.Reliability.Reliable(duration(seconds=2)), Policy.History.KeepLast(10),
              Policy.Durability.TransientLocal)
best_effort = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(5), Policy.Durability.Volatile)

# The bag, decoded by Cyclone's CDR.
messages = []
with open(args.bag, "rb") as f:
    for schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
        cls = R.BY_ROS_NAME.get(schema.name)
        if cls is None:
            continue
        try:
            sample = cls.deserialize(bytes(message.data))
        except Exception as e:  # a deliberately malformed message: not sendable as a typed sample
            print(f"peer: {channel.topic} @ {message.log_time}: not decodable by Cyclone, not sent ({e})")
            continue
        messages.append((channel.topic, cls, sample))
lists = [m for m in messages if m[0] == args.objects_topic]
print(f"peer: {len(messages)} messages from {args.bag}, {len(lists)} object lists")

dp = DomainParticipant(args.domain)
writers = {}
for topic, cls, _ in messages:
    if topic not in writers:
        qos = latched if topic == "/tf_static" else (
            best_effort if cls is R.PointCloud2 and args.cloud_best_effort else reliable)
        writers[topic] = DataWriter(dp, Topic(dp, "rt" + topic, cls), qos=qos)
verdict_reader = DataReader(dp, Topic(dp, "rt/pmon/verdicts", R.FrameVerdicts), qos=reliable)
diag_reader = DataReader(dp, Topic(dp, "rt/diagnostics", R.DiagnosticArray), qos=reliable)

t_start = time.monotonic()
deadline = t_start + args.timeout_s
while any(len(w.get_matched_subscriptions()) == 0 for w in writers.values()) or \
        len(verdict_reader.get_matched_publications()) == 0 or len(diag_reader.get_matched_publications()) == 0:
    if time.monotonic() > deadline:
        missing = [t for t, w in writers.items() if not w.get_matched_subscriptions()]
        print(f"peer: discovery timed out; unmatched writers {missing}")
        sys.exit(1)
    time.sleep(0.05)
print(f"peer: matched pmon's readers and writers after {time.monotonic() - t_start:.2f} s")
time.sleep(0.3)  # let both sides finish matching the remaining endpoints

verdicts, diags, sent_at = [], [], {}


def stamp_key(h):
    return (h.stamp.sec, h.stamp.nanosec)


def collect():
    for v in verdict_reader.take(N=100):
        v_time = time.monotonic()
        verdicts.append((v, v_time))
    for d in diag_reader.take(N=100):
        diags.append(d)


# tf_static first (latched), then the rest in log-time order, an object list every 1/rate s.
for topic, cls, sample in messages:
    if topic == "/tf_static":
        writers[topic].write(sample)
period = 1.0 / args.rate_hz
next_list = time.monotonic()
for topic, cls, sample in messages:
    if topic == "/tf_static":
        continue
    if topic == args.objects_topic:
        while time.monotonic() < next_list:
            collect()
            time.sleep(0.002)
        next_list += period
        sent_at[stamp_key(sample.header)] = time.monotonic()
    writers[topic].write(sample)
    collect()

while len(verdicts) < len(lists) and time.monotonic() < deadline:
    collect()
    time.sleep(0.01)
time.sleep(0.5)
collect()


def plain(x):
    if isinstance(x, (bytes, bytearray)):  # uint8 arrays come as bytes
        return list(x)
    if isinstance(x, dict):
        return {k: plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    return x


out = {
    "object_lists_sent": len(lists),
    "messages_sent": len(messages),
    "verdicts": [plain(asdict(v)) for v, _ in verdicts],
    "latency_s": [t - sent_at[stamp_key(v.header)] for v, t in verdicts if stamp_key(v.header) in sent_at],
    "diagnostics": [plain(asdict(d)) for d in diags],
}
with open(args.out, "w") as f:
    json.dump(out, f)
print(f"peer: sent {len(lists)} object lists, received {len(verdicts)} verdicts and {len(diags)} diagnostics")
sys.exit(0 if len(verdicts) >= len(lists) else 1)
