"""What a nuScenes v1.0 scene task costs with and without its table slice, and what cutting the slices costs.

    python python/benchmarks/nuscenes_tables.py /tmp/nus-val --scenes 150         # generated tables, val's size
    python python/benchmarks/nuscenes_slices.py /tmp/nus-val --pmon target/release/pmon --tasks 3

1. `pmon evaluate nuscenes:ROOT --plan-only` (under /usr/bin/time): plans the run and cuts every scene's slice,
   reading each table once: wall time and peak resident memory.
2. For the `tracks` task of the first `--tasks` scenes, each in a fresh Python process with the pmon package: the
   task run from its slice (what `pmon evaluate` ships), then from the table folder (what every task did before the
   slices): wall time and peak resident memory of the process (`ru_maxrss`), alternating the two.

Prints a Markdown table. The Python package (the wheel) must be installed in this interpreter.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

CHILD = r"""
import json, resource, sys, time
from pmon import campaign
from pmon._pmon import run_evaluation_task
run_dir, ident, sliced = sys.argv[1], sys.argv[2], sys.argv[3] == "1"
task = next(t for t in json.load(open(run_dir + "/tasks.json")) if t["id"] == ident)
payload = campaign._payload(run_dir, task) if sliced else json.dumps(task)
t0 = time.perf_counter()
out = json.loads(run_evaluation_task(payload))
wall = time.perf_counter() - t0
assert "ok" in out["outcome"], out
print(json.dumps({"wall_s": wall, "maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "result": out}))
"""


def timed(cmd: list[str]) -> tuple[float, float, str]:
    """Runs cmd under /usr/bin/time -v: (wall seconds, peak RSS MB, stderr)."""
    p = subprocess.run(["/usr/bin/time", "-v", *cmd], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{p.stderr}")
    wall = re.search(r"Elapsed \(wall clock\) time.*: (?:(\d+):)?(\d+):([\d.]+)", p.stderr)
    h, m, s = wall.groups()
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr)
    return int(h or 0) * 3600 + int(m) * 60 + float(s), int(rss.group(1)) / 1024, p.stderr


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("root", help="nuScenes dataroot with one v1.0-* table folder")
    ap.add_argument("--pmon", default="pmon")
    ap.add_argument("--tasks", type=int, default=3, help="scene tasks to time, each both ways")
    args = ap.parse_args()
    size = sum(os.path.getsize(os.path.join(dp, f)) for dp, _, fs in os.walk(args.root) for f in fs
               if f.endswith(".json"))
    with tempfile.TemporaryDirectory() as tmp:
        run = os.path.join(tmp, "r.run")
        wall, rss, err = timed([args.pmon, "evaluate", f"nuscenes:{args.root}", "--smoke", "--plan-only",
                                "--run-dir", run, "--out", os.path.join(tmp, "r")])
        tasks = json.load(open(os.path.join(run, "tasks.json")))
        scenes = sorted({t["log"] for t in tasks})
        slice_mb = [os.path.getsize(os.path.join(run, "tables", f)) / 1e6 for f in os.listdir(os.path.join(run, "tables"))]
        print(f"tables: {size / 1e6:.0f} MB of JSON, {len(scenes)} scenes; slices: median {statistics.median(slice_mb):.2f} MB")
        print()
        print("| step | wall | peak RSS |")
        print("|---|---|---|")
        print(f"| plan + cut {len(scenes)} slices (`pmon evaluate --plan-only`, once per run) | {wall:.1f} s | {rss:.0f} MB |")
        rows: dict[bool, list[tuple[float, float]]] = {True: [], False: []}
        for scene in scenes[:args.tasks]:
            ident = next(t["id"] for t in tasks if t["log"] == scene and t["part"] == "tracks")
            results = {}
            for sliced in (True, False):
                p = subprocess.run([sys.executable, "-c", CHILD, run, ident, "1" if sliced else "0"],
                                   capture_output=True, text=True)
                if p.returncode != 0:
                    sys.exit(p.stderr)
                r = json.loads(p.stdout)
                rows[sliced].append((r["wall_s"], r["maxrss_mb"]))
                results[sliced] = r["result"]
            assert results[True] == results[False], f"{ident}: the results differ"
        for sliced, label in ((False, "the whole tables (before)"), (True, "its slice (now)")):
            w = [x[0] for x in rows[sliced]]
            m = [x[1] for x in rows[sliced]]
            print(f"| a scene's `tracks` task reading {label}, median of {len(w)} | {statistics.median(w):.2f} s "
                  f"| {statistics.median(m):.0f} MB |")
        print()
        print(f"(each pair of results identical; {len(scenes)} scenes x 2 parts = {len(tasks)} tasks)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
