"""An independent DDS peer for `pmon ros2` (Cyclone DDS from PyPI, not pmon's RustDDS): replays a rosbag2 MCAP
over DDS and records what pmon publishes.

Usage: dds_peer.py BAG.mcap OUT.json [--domain D] [--rate-hz R] [--timeout-s T] [--objects-topic TOPIC]

- Reads every message of the bag with the Python `mcap` reader and decodes its CDR with Cyclone's own
  deserializer into the types of ros2_types.py (written from the upstream .msg files, independent of pmon);
  a cloud Cyclone cannot decode (a deliberately cut one) is sent as a header-only PointCloud2 by a second
  participant, as a peer with a wrong type definition would (it does not decode at the receiver).
- Waits until pmon's readers have matched each of its writers (discovery), then publishes `/tf_static`
  (transient local) and the other messages in the bag's log-time order, one object list per 1/R s (the
  messages before an object list go out just before it: odometry, transforms, its cloud).
- Subscribes to `/pmon/verdicts` (pmon_msgs/FrameVerdicts) and `/diagnostics` (diagnostic_msgs/DiagnosticArray)
  and writes everything received to OUT.json, with the time from publishing each object list to receiving its
  verdicts (matched by stamp).
Exit status 0 when one verdict per object list arrived before the timeout, 1 otherwise.
"""
import argparse
import copy
import json
import sys
import time
from dataclasses import asdict

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds._clayer import ddspy_write
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
ap.add_argument("--repeat", type=int, default=1,
                help="replay the bag this many times, each time with the stamps shifted past the previous pass "
                     "(a load test: the verdicts then differ from pmon check of the bag)")
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
        except Exception as e:  # a deliberately malformed message (a cut cloud): its header only, as a peer
            # with a wrong PointCloud2 definition would send it (Cyclone will not send bytes its type rejects)
            if cls is not R.PointCloud2:
                raise
            sample = R.PointCloud2HeaderOnly.deserialize(bytes(message.data))
            cls = R.PointCloud2HeaderOnly
            print(f"peer: {channel.topic} @ {message.log_time}: not decodable by Cyclone ({e}): "
                  "sent as a header-only PointCloud2 from a second participant")
        messages.append((message.log_time, channel.topic == args.objects_topic, channel.topic, cls, sample))
# In log-time order; at equal log times an object list goes after its inputs (as a perception stack publishes).
messages = [m[2:] for m in sorted(messages, key=lambda m: (m[0], m[1]))]


def shifted(sample, dt_ns):
    """A copy with every header stamp moved by dt_ns (the point data is shared, not copied)."""
    sample = copy.copy(sample)
    headers = []
    if hasattr(sample, "header"):
        sample.header = copy.deepcopy(sample.header)
        headers.append(sample.header)
    if hasattr(sample, "transforms"):
        sample.transforms = copy.deepcopy(sample.transforms)
        headers += [tr.header for tr in sample.transforms]
    for h in headers:
        ns = h.stamp.sec * 1_000_000_000 + h.stamp.nanosec + dt_ns
        h.stamp.sec, h.stamp.nanosec = ns // 1_000_000_000, ns % 1_000_000_000
    return sample


if args.repeat > 1:
    stamps = [m[2].header.stamp.sec * 10**9 + m[2].header.stamp.nanosec for m in messages if m[0] == args.objects_topic]
    span = max(stamps) - min(stamps) + int(1e9 / args.rate_hz)
    once = [m for m in messages if m[0] != "/tf_static"]
    messages = [m for m in messages if m[0] == "/tf_static"] + once
    for c in range(1, args.repeat):
        messages += [(topic, cls, shifted(sample, c * span)) for topic, cls, sample in once]
lists = [m for m in messages if m[0] == args.objects_topic]
print(f"peer: {len(messages)} messages from {args.bag}, {len(lists)} object lists")

dp = DomainParticipant(args.domain)
writers = {}
bad_writers = {}
for topic, cls, _ in messages:
    if cls is R.PointCloud2HeaderOnly and topic not in bad_writers:
        dp_bad = DomainParticipant(args.domain)
        bad_writers[topic] = DataWriter(dp_bad, Topic(dp_bad, "rt" + topic, cls), qos=reliable)
    elif topic not in writers:
        qos = latched if topic == "/tf_static" else (
            best_effort if cls is R.PointCloud2 and args.cloud_best_effort else reliable)
        writers[topic] = DataWriter(dp, Topic(dp, "rt" + topic, cls), qos=qos)


def writer_of(topic, sample):
    return bad_writers[topic] if isinstance(sample, R.PointCloud2HeaderOnly) else writers[topic]


def serialized(topic, sample):
    """Cyclone's CDR of a sample, made before the replay starts: serialising a 120k-point cloud takes Cyclone's
    Python layer ~0.15 s, too slow to do at 10 Hz. Sent with the binding's raw write (what DataWriter.write
    does after serialising)."""
    w = writer_of(topic, sample)
    ser = sample.serialize(use_version_2=w._use_version_2)
    return ser.ljust((len(ser) + 3) & ~3, b"\0")


prepared = [(topic, sample, serialized(topic, sample)) for topic, _, sample in messages]
verdict_reader = DataReader(dp, Topic(dp, "rt/pmon/verdicts", R.FrameVerdicts), qos=reliable)
diag_reader = DataReader(dp, Topic(dp, "rt/diagnostics", R.DiagnosticArray), qos=reliable)

t_start = time.monotonic()
deadline = t_start + args.timeout_s
while any(len(w.get_matched_subscriptions()) == 0 for w in [*writers.values(), *bad_writers.values()]) or \
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




def send(topic, sample, ser):
    if ddspy_write(writer_of(topic, sample)._ref, ser) < 0:
        raise RuntimeError(f"write on {topic} failed")


# tf_static first (latched), then the rest in log-time order, an object list every 1/rate s.
for topic, sample, ser in prepared:
    if topic == "/tf_static":
        send(topic, sample, ser)
period = 1.0 / args.rate_hz
next_list = t_replay = time.monotonic()
late = 0
for topic, sample, ser in prepared:
    if topic == "/tf_static":
        continue
    if topic == args.objects_topic:
        if time.monotonic() > next_list + period:
            late += 1  # the peer itself fell behind the rate
        while time.monotonic() < next_list:
            collect()
            time.sleep(0.002)
        next_list += period
        sent_at[stamp_key(sample.header)] = time.monotonic()
    send(topic, sample, ser)
    collect()

replay_s = time.monotonic() - t_replay
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
    "replay_s": replay_s,
    "lists_sent_late": late,
    "latency_s": [t - sent_at[stamp_key(v.header)] for v, t in verdicts if stamp_key(v.header) in sent_at],
    "diagnostics": [plain(asdict(d)) for d in diags],
}
with open(args.out, "w") as f:
    json.dump(out, f)
print(f"peer: replay {replay_s:.1f} s ({late} lists sent late), sent {len(lists)} object lists, received {len(verdicts)} verdicts and {len(diags)} diagnostics")
sys.exit(0 if len(verdicts) >= len(lists) else 1)
