"""Reads pmon's results MCAP with the Python `mcap` reader, decodes the CDR with `mcap-ros2-support`, and
checks the field values against the scene make_bag.py wrote (independent of pmon's own code).
Usage: check_results.py RESULTS.mcap INPUT.mcap VERDICTS.jsonl
"""
import base64
import json
import sys
from collections import Counter

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

results, bag, jsonl = sys.argv[1], sys.argv[2], sys.argv[3]


def topic_counts(path):
    with open(path, "rb") as f:
        return Counter(ch.topic for _, ch, _ in make_reader(f).iter_messages())


# The input topics are copied unchanged.
inp, out = topic_counts(bag), topic_counts(results)
for topic, n in inp.items():
    assert out[topic] == n, (topic, n, out[topic])
assert out["/pmon/verdicts"] == 3 and out["/diagnostics"] == 3, out
assert out["/pmon/scene"] == 3 and out["/pmon/grid"] == 3, out

with open(results, "rb") as f:
    reader = make_reader(f, decoder_factories=[DecoderFactory()])
    verdicts, diags = [], []
    for schema, channel, message, msg in reader.iter_decoded_messages(topics=["/pmon/verdicts", "/diagnostics"]):
        (verdicts if channel.topic == "/pmon/verdicts" else diags).append(msg)
    assert schema.name in ("pmon_msgs/msg/FrameVerdicts", "diagnostic_msgs/msg/DiagnosticArray")

stamps = [v.header.stamp.sec + v.header.stamp.nanosec * 1e-9 for v in verdicts]
assert [round(s, 3) for s in stamps] == [1.0, 1.1, 1.3], stamps
for v in verdicts[:2]:
    assert v.header.frame_id == "map" and v.cloud_paired and v.sensor_status == "", v
    byid = {o.id: o for o in v.objects}
    assert set(byid) == {1, 2}, byid
    assert byid[1].verdict == 0 and byid[1].verdict_name == "consistent", byid[1]
    assert byid[2].verdict == 1 and byid[2].verdict_name == "ghost", byid[2]
    assert list(byid[2].object_id.uuid)[0] == 2 and list(byid[2].object_id.uuid)[15] == 0xAB
    assert abs(byid[1].x_m - 10.0) < 1e-3 and abs(byid[2].y_m - 6.0) < 1e-3
    assert byid[1].eta > 0.9 and byid[2].eta <= 0.5 and byid[2].visible_fraction > 0.9, (byid[1], byid[2])
    assert len(v.missed) == 1, v.missed
    cx, cy = v.missed[0].centroid_m
    assert abs(cx - 15.0) < 1.0 and abs(cy + 8.0) < 1.0, (cx, cy)
    assert v.points_total > 10000 and v.processing_time_s > 0.0
last = verdicts[2]
assert not last.cloud_paired and last.sensor_status == "no_lidar_data", last
assert all(o.verdict_name != "ghost" for o in last.objects)

for d, v in zip(diags, verdicts):
    (st,) = d.status
    kv = {x.key: x.value for x in st.values}
    assert st.name == "pmon: perception monitor" and st.hardware_id == "pmon"
    if v.cloud_paired:
        assert st.level == 2, st  # ERROR: alarms
        assert kv["alarms"] == "1" and kv["missed_objects"] == "1" and kv["object 2"].startswith("ghost"), kv
        assert "missed object" in kv
    else:
        assert st.level == 1 and kv["sensor_status"] == "no_lidar_data", st  # WARN: sensor checks not run

with open(results, "rb") as f:
    for schema, channel, message in make_reader(f).iter_messages(topics=["/pmon/scene", "/pmon/grid"]):
        assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
        m = json.loads(message.data)
        if channel.topic == "/pmon/scene":
            assert schema.name == "foxglove.SceneUpdate"
            (e,) = m["entities"]
            assert e["frame_id"] == "base_link"
            labels = [t["text"] for t in e["texts"]]
            if message.log_time < 1_200_000_000:
                assert "car 2: ghost" in labels and "car 1: consistent" in labels, labels
                assert any(l.startswith("missed object") for l in labels), labels
                red = [c for c in e["cubes"] if c["color"]["r"] > 0.8 and c["color"]["g"] < 0.2]
                assert len(red) == 1 and abs(red[0]["pose"]["position"]["x"] - 20.0) < 1e-3, red
        else:
            assert schema.name == "foxglove.Grid"
            data = base64.b64decode(m["data"])
            assert len(data) == m["column_count"] * m["row_stride"] // m["cell_stride"], len(data)
            if message.log_time < 1_200_000_000:
                c = Counter(data)
                assert c[3] > 0 and c[2] > 0, c  # conflict cells (the missed object) and explained cells
                # The conflict cells lie around ego (15, -8).
                n, cs, ox = m["column_count"], m["cell_size"]["x"], m["pose"]["position"]["x"]
                xs = [ox + (i % n + 0.5) * cs for i, v in enumerate(data) if v == 3]
                ys = [ox + (i // n + 0.5) * cs for i, v in enumerate(data) if v == 3]
                assert abs(sum(xs) / len(xs) - 15.0) < 1.0 and abs(sum(ys) / len(ys) + 8.0) < 1.0

# The JSON lines pmon printed agree with the MCAP.
lines = [json.loads(l) for l in open(jsonl)]
assert [[o["verdict_name"] for o in l["objects"]] for l in lines] == [
    [o.verdict_name for o in v.objects] for v in verdicts]
print("results OK:", dict(out))
