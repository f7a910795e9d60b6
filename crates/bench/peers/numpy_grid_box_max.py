#!/usr/bin/env python3
"""The numpy peer of `pmon bench` (issue #16): the grid-plus-box-max part of the sensor checks, vectorised.

Per frame: the sweep into the ego frame (a translation, as the benchmark's extrinsics are), the obstacle height
band, a count per grid cell (`np.bincount`), and the maximum count over the cells under each object box (the cells
that overlap the box with positive area: pmon's separating-axis test, in float32, operation for operation, over all
boxes at once). Reads the frames that `pmon bench --export-peers DIR` writes (format in crates/bench/src/peers.rs),
checks its per-box maxima against pmon's, and prints the median time per frame on one line:

    peer=numpy case=NAME median_us=... p99_us=... max_us=... samples=... agree=K/M

Usage: numpy_grid_box_max.py CASE_DIR [ITERATIONS]. Needs numpy (2.x); exit status 1 when a maximum differs.
"""

import struct
import sys
import time
from pathlib import Path

import numpy as np

F32 = np.float32


def bits(hexbits):
    return np.frombuffer(struct.pack("<I", int(hexbits, 16)), dtype="<f4")[0]


def load(case_dir):
    meta = {"sweeps": [], "frames": []}
    for line in (case_dir / "case.txt").read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        key = parts[0]
        if key == "name":
            meta["name"] = parts[1]
        elif key in ("cell_size_m", "inv_cell", "origin_m", "band_lo_m", "band_hi_m"):
            meta[key] = bits(parts[2])
        elif key == "cells_per_side":
            meta["n"] = int(parts[1])
        elif key == "sweep":
            meta["sweeps"].append(np.fromfile(case_dir / parts[1], dtype="<f4").reshape(-1, 3))
        elif key == "frame":
            t = np.array([bits(p) for p in parts[2:5]], dtype=F32)
            boxes = np.fromfile(case_dir / parts[5], dtype="<f4").reshape(-1, 6)
            expected = np.fromfile(case_dir / parts[6], dtype="<u4")
            meta["frames"].append((int(parts[1]), t, boxes, expected))
    return meta


def grid_box_max(points, t, boxes, m):
    """Per-box maximum of the per-cell counts of the points in the band."""
    n, origin, inv, cell = m["n"], m["origin_m"], m["inv_cell"], m["cell_size_m"]
    nf = F32(n)
    q = points + t
    keep = np.isfinite(q).all(axis=1) & (q[:, 2] >= m["band_lo_m"]) & (q[:, 2] <= m["band_hi_m"])
    fx = (q[:, 0] - origin) * inv
    fy = (q[:, 1] - origin) * inv
    keep &= (fx >= 0) & (fx < nf) & (fy >= 0) & (fy < nf)
    idx = fy[keep].astype(np.int64) * n + fx[keep].astype(np.int64)
    counts = np.bincount(idx, minlength=n * n)

    cx, cy, cos, sin, hl, hw = (boxes[:, k] for k in range(6))
    c, s = np.abs(cos), np.abs(sin)
    ex = hl * c + hw * s
    ey = hl * s + hw * c
    col = lambda v: np.floor((v - origin) * inv).astype(np.int64)
    x0 = np.clip(col(cx - ex) - 1, 0, n - 1)
    x1 = np.clip(col(cx + ex) + 1, 0, n - 1)
    y0 = np.clip(col(cy - ey) - 1, 0, n - 1)
    y1 = np.clip(col(cy + ey) + 1, 0, n - 1)
    kx, ky = x1 - x0 + 1, y1 - y0 + 1
    k = kx * ky
    starts = np.concatenate(([0], np.cumsum(k)[:-1]))
    box = np.repeat(np.arange(len(boxes)), k)
    local = np.arange(k.sum()) - starts[box]
    ix = x0[box] + local % kx[box]
    iy = y0[box] + local // kx[box]
    half = F32(0.5) * cell
    px = origin + (ix.astype(F32) + F32(0.5)) * cell
    py = origin + (iy.astype(F32) + F32(0.5)) * cell
    # pmon's OrientedRect::overlaps_square, in pmon's order of operations.
    dx = px - cx[box]
    dy = py - cy[box]
    cb, sb, hlb, hwb = c[box], s[box], hl[box], hw[box]
    hit = np.abs(dx) < half + hlb * cb + hwb * sb
    hit &= np.abs(dy) < half + hlb * sb + hwb * cb
    du = dx * cos[box] + dy * sin[box]
    dv = -dx * sin[box] + dy * cos[box]
    hs = half * (cb + sb)
    hit &= (np.abs(du) < hlb + hs) & (np.abs(dv) < hwb + hs)
    vals = np.where(hit, counts[iy * n + ix], 0)
    return np.maximum.reduceat(vals, starts) if len(boxes) else np.zeros(0, np.int64)


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    case_dir = Path(sys.argv[1])
    iterations = max(1, int(sys.argv[2])) if len(sys.argv) > 2 else 300
    m = load(case_dir)
    frames = m["frames"]
    if not frames:
        print(f"{case_dir}: no frames", file=sys.stderr)
        return 2
    agree = total = 0
    for sweep, t, boxes, expected in frames:
        got = np.minimum(grid_box_max(m["sweeps"][sweep], t, boxes, m), 255)
        total += max(len(got), len(expected))
        if len(got) == len(expected):
            agree += int((got == expected).sum())
    for sweep, t, boxes, _ in frames:  # warm-up: one cycle
        grid_box_max(m["sweeps"][sweep], t, boxes, m)
    us = []
    for i in range(iterations):
        sweep, t, boxes, _ = frames[i % len(frames)]
        t0 = time.perf_counter_ns()
        grid_box_max(m["sweeps"][sweep], t, boxes, m)
        us.append((time.perf_counter_ns() - t0) / 1e3)
    us.sort()
    median = float(np.median(us))
    p99 = us[min(len(us), max(1, int(np.ceil(0.99 * len(us))))) - 1]
    print(
        f"peer=numpy case={m['name']} median_us={median:.2f} p99_us={p99:.2f} max_us={us[-1]:.2f} "
        f"samples={len(us)} agree={agree}/{total}",
        flush=True,
    )
    return 0 if agree == total else 1


if __name__ == "__main__":
    sys.exit(main())
