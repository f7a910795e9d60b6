"""Writes generated nuScenes v1.0 tables at the scale of a real split, for measuring what reading them costs.

No v1.0 tables of a whole split are on this machine, so the cost of reading them per scene task (before scene
slices) and once per run (with them) is measured on generated tables with the row counts of v1.0-trainval
(per scene: 40 samples; per sample: about 78 sample_data rows, as 6 cameras at 12 Hz, the LiDAR at 20 Hz and 5
radars at 13 Hz give in 0.5 s, each with its ego pose; 34 annotations of about 75 instances per scene). The rows
have the v1.0 fields and value formats (32-hex tokens, microsecond timestamps, 17-digit floats). No sweep file is
written (a `tracks` task does not read them, a `sensor` task reports the frames without a cloud) unless
`--points N` asks for a LIDAR_TOP keyframe sweep of N points each: a ground plane and the annotated boxes'
surfaces, as load for the sensor checks, not as a realistic scene.

    python python/benchmarks/nuscenes_tables.py OUT --scenes 850       # trainval's size (about 2.3 GB)
    python python/benchmarks/nuscenes_tables.py OUT --scenes 150       # val's size

Written independently of pmon's reader (the nuScenes schema as the devkit documents it).
"""

from __future__ import annotations

import argparse
import array
import json
import math
import os
import random
import sys
import time

CHANNELS = [("CAM_FRONT", "camera", 6), ("CAM_FRONT_LEFT", "camera", 6), ("CAM_FRONT_RIGHT", "camera", 6),
            ("CAM_BACK", "camera", 6), ("CAM_BACK_LEFT", "camera", 6), ("CAM_BACK_RIGHT", "camera", 6),
            ("LIDAR_TOP", "lidar", 10),
            ("RADAR_FRONT", "radar", 7), ("RADAR_FRONT_LEFT", "radar", 6), ("RADAR_FRONT_RIGHT", "radar", 7),
            ("RADAR_BACK_LEFT", "radar", 6), ("RADAR_BACK_RIGHT", "radar", 7)]   # rows per 0.5 s sample


class Table:
    """A JSON array written row by row (the devkit's tables are arrays of objects, indented)."""

    def __init__(self, path: str) -> None:
        self.f = open(path, "w", encoding="utf-8")
        self.f.write("[")
        self.n = 0

    def row(self, r: dict) -> None:
        self.f.write(",\n" if self.n else "\n")
        self.f.write(json.dumps(r, indent=None))
        self.n += 1

    def close(self) -> None:
        self.f.write("\n]\n")
        self.f.close()


def write_sweep(path: str, n: int, boxes: list, rng: random.Random) -> None:
    """N points (x, y, z, intensity, ring as little-endian f32) in the LiDAR frame, which the generated
    calibration turns by -90 degrees: half on the ground, half on the boxes' sides (4.6 x 1.9 m)."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    pts = array.array("f")
    for k in range(n):
        if k % 2 or not boxes:
            x, y, z = rng.uniform(-50, 50), rng.uniform(-50, 50), -1.8
        else:
            bx, by, yaw = boxes[k // 2 % len(boxes)]
            u, v = rng.uniform(-2.3, 2.3), rng.choice([-0.95, 0.95])
            ex, ey = bx + u * math.cos(yaw) - v * math.sin(yaw), by + u * math.sin(yaw) + v * math.cos(yaw)
            x, y, z = -ey, ex, rng.uniform(-1.5, 0.0)   # ego -> sensor: the inverse of the -90 degree turn
        pts.extend((x, y, z, 1.0, float(k % 32)))
    if sys.byteorder != "little":
        pts.byteswap()
    with open(path, "wb") as f:
        pts.tofile(f)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", help="dataroot to write (gets a v1.0-synthetic folder); must not exist")
    ap.add_argument("--scenes", type=int, default=150)
    ap.add_argument("--samples", type=int, default=40, help="samples (keyframes at 2 Hz) per scene")
    ap.add_argument("--annotations", type=int, default=34, help="annotations per sample")
    ap.add_argument("--instances", type=int, default=75, help="instances per scene")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--points", type=int, default=0, help="write a LIDAR_TOP keyframe sweep of this many points")
    args = ap.parse_args()
    if os.path.exists(args.out):
        sys.exit(f"{args.out} exists: choose a new folder")
    rng = random.Random(args.seed)
    tok = lambda: "%032x" % rng.getrandbits(128)  # noqa: E731
    d = os.path.join(args.out, "v1.0-synthetic")
    os.makedirs(d)
    t0 = time.perf_counter()

    sensors, cals = [], []
    for ch, modality, _ in CHANNELS:
        sensors.append({"token": tok(), "channel": ch, "modality": modality})
    with open(os.path.join(d, "sensor.json"), "w") as f:
        json.dump(sensors, f, indent=0)
    cats = [{"token": tok(), "name": n, "description": ""} for n in
            ["vehicle.car", "human.pedestrian.adult", "vehicle.truck", "vehicle.bicycle", "movable_object.barrier",
             "movable_object.trafficcone"]]
    with open(os.path.join(d, "category.json"), "w") as f:
        json.dump(cats, f, indent=0)

    tables = {n: Table(os.path.join(d, n)) for n in
              ["scene.json", "sample.json", "sample_data.json", "ego_pose.json", "sample_annotation.json",
               "instance.json", "calibrated_sensor.json"]}
    ts = 1_531_281_439_800_013
    for sc in range(args.scenes):
        scene_tok = tok()
        # one calibration per sensor per scene (the devkit's logs: one per log)
        cal_of = {}
        for s in sensors:
            c = {"token": tok(), "sensor_token": s["token"],
                 "translation": [rng.uniform(-1, 2), rng.uniform(-1, 1), rng.uniform(0.5, 2)],
                 "rotation": [0.7071067811865476, 0.0, 0.0, -0.7071067811865475], "camera_intrinsic": []}
            cal_of[s["channel"]] = c["token"]
            tables["calibrated_sensor.json"].row(c)
        inst = [(tok(), rng.choice(cats)["token"], rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-3, 3))
                for _ in range(args.instances)]
        for i, c, *_ in inst:
            tables["instance.json"].row({"token": i, "category_token": c, "nbr_annotations": args.samples,
                                         "first_annotation_token": "", "last_annotation_token": ""})
        samples = [tok() for _ in range(args.samples)]
        tables["scene.json"].row({"token": scene_tok, "log_token": tok(), "nbr_samples": args.samples,
                                  "first_sample_token": samples[0], "last_sample_token": samples[-1],
                                  "name": f"scene-{sc + 1:04d}", "description": "generated"})
        ex, ey, eyaw = rng.uniform(0, 2000), rng.uniform(0, 2000), rng.uniform(-math.pi, math.pi)
        for k, s in enumerate(samples):
            ts += 500_000
            tables["sample.json"].row({"token": s, "timestamp": ts, "prev": samples[k - 1] if k else "",
                                       "next": samples[k + 1] if k + 1 < len(samples) else "",
                                       "scene_token": scene_tok})
            ex, ey = ex + 5 * math.cos(eyaw), ey + 5 * math.sin(eyaw)
            for ch, modality, n in CHANNELS:
                for j in range(n):
                    t = ts + j * (500_000 // n)
                    ep = tok()
                    tables["ego_pose.json"].row({"token": ep, "timestamp": t,
                                                 "rotation": [math.cos(eyaw / 2), 0.0, 0.0, math.sin(eyaw / 2)],
                                                 "translation": [ex + rng.uniform(-0.1, 0.1), ey, 0.0]})
                    ext = {"camera": "jpg", "lidar": "pcd.bin", "radar": "pcd"}[modality]
                    folder = "samples" if j == 0 else "sweeps"
                    tables["sample_data.json"].row({
                        "token": tok(), "sample_token": s, "ego_pose_token": ep, "calibrated_sensor_token": cal_of[ch],
                        "timestamp": t, "fileformat": ext.split(".")[0], "is_key_frame": j == 0,
                        "height": 900 if modality == "camera" else 0, "width": 1600 if modality == "camera" else 0,
                        "filename": f"{folder}/{ch}/n008-2018-08-01-15-16-36-0400__{ch}__{t}.{ext}",
                        "prev": "", "next": ""})
            if args.points:
                write_sweep(os.path.join(args.out, "samples", "LIDAR_TOP",
                                         f"n008-2018-08-01-15-16-36-0400__LIDAR_TOP__{ts}.pcd.bin"), args.points,
                            [(x, y, yaw) for _, _, x, y, yaw in inst[:args.annotations]], rng)
            for a in range(args.annotations):
                i, _, x, y, yaw = inst[a % len(inst)]
                tables["sample_annotation.json"].row({
                    "token": tok(), "sample_token": s, "instance_token": i, "visibility_token": "4",
                    "attribute_tokens": [tok()], "translation": [ex + x + 0.3 * k, ey + y, rng.uniform(0.5, 1.5)],
                    "size": [1.9, 4.6, 1.7], "rotation": [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)],
                    "prev": "", "next": "", "num_lidar_pts": rng.randrange(0, 300), "num_radar_pts": 0})
    for t in tables.values():
        t.close()
    size = sum(os.path.getsize(os.path.join(d, n)) for n in os.listdir(d))
    rows = {n: t.n for n, t in tables.items()}
    print(f"{d}: {size / 1e6:.0f} MB, rows {rows}, {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
