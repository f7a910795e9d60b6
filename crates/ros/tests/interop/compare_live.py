"""Compares what the DDS peer received from `pmon ros2` with `pmon check` on the same bag.

Usage: compare_live.py PEER.json CHECK.jsonl RESULTS.mcap SUMMARY.json

- verdicts: one per object list, in order, every field equal to `pmon check --format jsonl` (float32 fields
  bit-equal; NaN is `null` in JSON) except `processing_time_s` (a wall time);
- /diagnostics: the frame status (`pmon: perception monitor`) equal to the one in `pmon check --out
  results.mcap` (read with the Python `mcap` reader and `mcap-ros2-support`), except the value of
  `processing_time_ms`; the per-check statuses' levels recomputed here from the verdict codes (docs/ros2.md);
- writes the counts compared and the peer's latencies (median, p99) to SUMMARY.json.
Exit status 0 when everything matches, 1 with the first differences printed otherwise.
"""
import json
import math
import struct
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

peer_path, check_path, results_path, summary_path = sys.argv[1:5]
peer = json.load(open(peer_path))
check = [json.loads(line) for line in open(check_path) if line.strip()]
errors = []


def f32(x):
    if x is None:
        return "nan"
    if isinstance(x, float) and math.isnan(x):
        return "nan"
    return struct.unpack("<f", struct.pack("<f", x))[0]


FLOAT32 = {"x_m", "y_m", "eta", "visible_fraction", "offset_m", "centroid_m", "bounds_m"}


def same(a, b, path, skip=("processing_time_s",)):
    """Structural equality of a peer sample (a) and pmon check's JSON (b)."""
    if isinstance(b, dict):
        if not isinstance(a, dict) or set(a) != set(b):
            errors.append(f"{path}: keys {sorted(a) if isinstance(a, dict) else a} != {sorted(b)}")
            return
        for k in b:
            if k not in skip:
                same(a[k], b[k], f"{path}.{k}", skip)
    elif isinstance(b, list):
        if not isinstance(a, list) or len(a) != len(b):
            errors.append(f"{path}: {a} != {b}")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{path}[{i}]", skip)
    elif path.split(".")[-1].split("[")[0] in FLOAT32:
        if f32(a) != f32(b):
            errors.append(f"{path}: {a} != {b}")
    elif a != b and not (b is None and isinstance(a, float) and math.isnan(a)):
        errors.append(f"{path}: {a!r} != {b!r}")


live = peer["verdicts"]
if len(live) != len(check):
    errors.append(f"{len(live)} verdicts from the node, {len(check)} from pmon check")
for i, (a, b) in enumerate(zip(live, check)):
    same(a, b, f"frame {i}")

# /diagnostics of pmon check's results file.
bag_diags = []
with open(results_path, "rb") as f:
    reader = make_reader(f, decoder_factories=[DecoderFactory()])
    for _, _, _, msg in reader.iter_decoded_messages(topics=["/diagnostics"]):
        (st,) = msg.status
        bag_diags.append({"level": st.level, "name": st.name, "message": st.message,
                          "hardware_id": st.hardware_id, "values": [(kv.key, kv.value) for kv in st.values]})
frame_diags = [d for d in peer["diagnostics"] if d["status"] and d["status"][0]["name"] == "pmon: perception monitor"]
if len(frame_diags) != len(bag_diags):
    errors.append(f"{len(frame_diags)} frame diagnostics from the node, {len(bag_diags)} in pmon check's results")
LEVEL = {"OK": 0, "WARN": 1, "ERROR": 2, "STALE": 3}
levels_seen = {}
for i, (d, b) in enumerate(zip(frame_diags, bag_diags)):
    st = d["status"][0]
    for k in ("level", "name", "message", "hardware_id"):
        if (st[k] if k != "level" else int(st[k])) != b[k]:
            errors.append(f"diagnostics {i}: {k} {st[k]!r} != {b[k]!r}")
    a_vals = [(kv["key"], kv["value"]) for kv in st["values"] if kv["key"] != "processing_time_ms"]
    b_vals = [kv for kv in b["values"] if kv[0] != "processing_time_ms"]
    if a_vals != b_vals:
        errors.append(f"diagnostics {i}: values {a_vals} != {b_vals}")
    # The per-check statuses, recomputed from the verdicts of the same frame.
    v = live[i] if i < len(live) else None
    if v is None:
        continue
    codes = [o["verdict"] for o in v["objects"]]
    ran = v["sensor_status"] == ""
    expect = {
        "pmon: object consistency": "ERROR" if any(c in (1, 2) for c in codes) else ("OK" if ran else "WARN"),
        "pmon: missed objects": "ERROR" if v["missed"] else ("OK" if ran else "WARN"),
        "pmon: motion plausibility": "ERROR" if 3 in codes else "OK",
        "pmon: sensor input": "OK" if ran else "WARN",
    }
    got = {s["name"]: int(s["level"]) for s in d["status"][1:]}
    for name, lvl in expect.items():
        if got.get(name) != LEVEL[lvl]:
            errors.append(f"diagnostics {i}: {name} level {got.get(name)} != {lvl}")
        levels_seen.setdefault(name, set()).add(lvl)
    if "pmon: node" not in got:
        errors.append(f"diagnostics {i}: no 'pmon: node' status")


# Every `pmon: node` status names the parameters the node runs with (key `params`).
node_statuses = [s for d in peer["diagnostics"] for s in d["status"] if s["name"] == "pmon: node"]
node_params = sorted({kv["value"] for s in node_statuses for kv in s["values"] if kv["key"] == "params"})
unnamed = sum(1 for s in node_statuses if not any(kv["key"] == "params" for kv in s["values"]))
if unnamed:
    errors.append(f"{unnamed} 'pmon: node' statuses without the key 'params'")


def q(v, p):
    if not v:
        return None
    s = sorted(v)
    return s[max(0, min(len(s) - 1, math.ceil(p * len(s)) - 1))]


objects = sum(len(v["objects"]) for v in live)
alarms = sum(1 for v in live for o in v["objects"] if o["verdict"] in (1, 2, 3))
summary = {
    "frames_compared": min(len(live), len(check)),
    "object_verdicts_compared": objects,
    "object_alarms": alarms,
    "missed_objects": sum(len(v["missed"]) for v in live),
    "diagnostics_compared": min(len(frame_diags), len(bag_diags)),
    "levels_seen": {k: sorted(v) for k, v in levels_seen.items()},
    "node_params": node_params,
    "peer_latency_ms_median": None if not peer["latency_s"] else 1e3 * q(peer["latency_s"], 0.5),
    "peer_latency_ms_p99": None if not peer["latency_s"] else 1e3 * q(peer["latency_s"], 0.99),
    "node_check_ms_median": 1e3 * q([v["processing_time_s"] for v in live], 0.5) if live else None,
    "differences": len(errors),
}
json.dump(summary, open(summary_path, "w"), indent=1)
print(json.dumps(summary))
for e in errors[:20]:
    print("DIFF", e)
sys.exit(1 if errors else 0)
