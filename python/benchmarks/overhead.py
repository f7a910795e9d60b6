#!/usr/bin/env python3
"""Per-frame overhead of the Python call over the Rust call, side by side in one run.

The frames are the 64-beam synthetic frames of `pmon bench` (120,000 points, 100 objects;
crates/bench/src/frames.rs), made by the extension itself, converted once to what a Python caller holds
(a contiguous (N, 3) float32 array and a dict of object columns). Each iteration times

- `python_call_us`: `Monitor.check(...)` as a user calls it, from Python, until the result dict is built;
- `core_us`: the Rust call inside it (`Session::check`, i.e. `Monitor::check`), timed in Rust around the call.

The difference is what the Python layer costs per frame: argument checks, the object columns, the GIL
release and the result arrays. Medians over the iterations; run it on a release build of the wheel
(`pip install ./python`), since a dev build's core is not optimised like a user's.

    python python/benchmarks/overhead.py [--iterations 300] [--frames 64-beam|32-beam] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

import pmon
from pmon import _pmon
from pmon._frames import Frame


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--iterations", type=int, default=300)
    ap.add_argument("--frames", default="64-beam")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    frames = [Frame._from_core(d) for d in _pmon.synthetic_frames(args.frames)]
    monitor = pmon.Monitor()
    total, core = [], []
    for i in range(args.iterations):
        f = frames[i % len(frames)]
        t0 = time.perf_counter()
        r = monitor.check(f.points, f.objects, timestamp_s=0.1 * i, world_from_ego=f.world_from_ego,
                          ego_from_sensor=f.ego_from_sensor, _core_time=True)
        t1 = time.perf_counter()
        total.append((t1 - t0) * 1e6)
        core.append(r.core_time_s * 1e6)
    warm = max(1, args.iterations // 10)  # the first calls fill caches and buffers
    med_total, med_core = statistics.median(total[warm:]), statistics.median(core[warm:])
    diff = [a - b for a, b in zip(total[warm:], core[warm:])]
    med_diff = statistics.median(diff)
    out = {
        "frames": args.frames,
        "points": int(frames[0].points.shape[0]),
        "objects": int(len(frames[0].objects["id"])),
        "iterations": args.iterations - warm,
        "core_us": round(med_core, 1),
        "python_call_us": round(med_total, 1),
        "overhead_us": round(med_diff, 1),
        "overhead_percent": round(100 * med_diff / med_core, 1),
    }
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{args.frames}: {out['points']} points, {out['objects']} objects, {out['iterations']} iterations (medians)")
        print(f"  Rust call (Monitor::check)   {out['core_us']:9.1f} us")
        print(f"  Python call (Monitor.check)  {out['python_call_us']:9.1f} us")
        print(f"  overhead                     {out['overhead_us']:9.1f} us  ({out['overhead_percent']} %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
