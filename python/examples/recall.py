#!/usr/bin/env python3
"""Recall of the sensor checks for displaced objects, on a dataset or a pmon recording, with the pmon package.

Every object of every frame is moved by `d` metres in a direction drawn once per track (seeded: the same run
gives the same numbers), the monitor checks the frames, and the share of displaced objects it flags
(position error or ghost) is the recall at `d`. Only objects the monitor confirmed without the displacement
count (the verifiable ones: an object without LiDAR evidence cannot be checked); at `d = 0` the share of
those flagged is the false-alarm rate. One line per offset is printed; with matplotlib installed the curve is
saved as a PNG.

    python examples/recall.py kitti:../shared/data/kitti/object/training --out recall.png
    python examples/recall.py my-recording/            # a pmon recording (pmon simulate / pmon convert)
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import pmon


def open_source(spec: str):
    """A `scheme:path` dataset spec or a recording path, as the `pmon check` command takes it."""
    scheme = spec.split(":", 1)[0]
    if ":" in spec and scheme in pmon.datasets.SCHEMES:
        return pmon.datasets.open(spec)
    return pmon.read_recording(spec)


def displaced(frame: pmon.Frame, d: float, seed: int) -> dict:
    """The frame's objects moved by `d` metres, each track in its own seeded direction."""
    o = dict(frame.objects)
    ids = np.asarray(o["id"], dtype=np.uint64)
    angle = np.array([np.random.default_rng([seed, int(i)]).uniform(0, 2 * np.pi) for i in ids])
    o["x"] = np.asarray(o["x"], dtype=np.float32) + np.float32(d) * np.cos(angle).astype(np.float32)
    o["y"] = np.asarray(o["y"], dtype=np.float32) + np.float32(d) * np.sin(angle).astype(np.float32)
    return o


def verdicts(frames, params, d: float, seed: int) -> list:
    monitor = pmon.Monitor(params)
    out = []
    for f in frames:
        r = monitor.check(f.points, displaced(f, d, seed), timestamp_s=f.timestamp_s,
                          world_from_ego=f.world_from_ego, roi=f.roi, static=f.static,
                          ego_from_sensor=f.ego_from_sensor)
        out.append(r.objects["verdict"])
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source", help="scheme:path (kitti:, nuscenes:, av2:, ...) or a pmon recording")
    ap.add_argument("--offsets", default="0,0.5,1,1.5,2,3", help="displacements in metres, comma-separated")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--out", help="save the recall curve here (PNG; needs matplotlib)")
    args = ap.parse_args(argv)
    src = open_source(args.source)
    frames = [f for f in src if f.points is not None]
    if not frames:
        print(f"{args.source}: no frame with a LiDAR sweep: the sensor checks cannot run", file=sys.stderr)
        return 2
    offsets = [float(x) for x in args.offsets.split(",")]
    clean = verdicts(frames, src.params, 0.0, args.seed)
    verifiable = [v == "consistent" for v in clean]
    n = int(sum(m.sum() for m in verifiable))
    print(f"{args.source}: {len(frames)} frames, {sum(len(v) for v in clean)} objects, {n} verifiable")
    rows = []
    for d in offsets:
        flagged = 0
        for v, keep in zip(verdicts(frames, src.params, d, args.seed), verifiable):
            flagged += int(np.isin(v[keep], ["position_error", "ghost"]).sum())
        share = flagged / n if n else float("nan")
        rows.append((d, share))
        label = "false alarms" if d == 0 else "recall"
        print(f"  d = {d:4.1f} m   {label:12s} {100 * share:5.1f} %   ({flagged} of {n})")
    if args.out:
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            print("matplotlib is not installed: no plot (pip install matplotlib)", file=sys.stderr)
            return 0
        fig, ax = plt.subplots(figsize=(5, 3.2))
        ax.plot([d for d, _ in rows], [100 * s for _, s in rows], marker="o")
        ax.set_xlabel("displacement d (m)")
        ax.set_ylabel("flagged (%)")
        ax.set_title(f"pmon sensor checks: {src.name}", fontsize=9)
        ax.set_ylim(0, 100)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(args.out, dpi=120)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
