"""Cost of `pmon evaluate` tasks in-process and on a Dask LocalCluster of 1 and 2 workers, side by side in one run.

A task runs its passes on a rayon pool inside the Rust call, so one task alone can use every core. For a clean
scaling measurement each Dask worker gets ``RAYON_NUM_THREADS=--rayon-threads`` (default 1: one core per worker),
and the in-process rows are ``pmon evaluate --scheduler local --threads 1`` and ``--threads 2`` (one rayon pool of
that many threads for the tasks and the passes inside them), timed around the command (merge included).

The source's logs are linked (symbolic links, nothing copied) ``--copies`` times under new names into a
temporary folder, so that there are enough tasks to share out. ``pmon evaluate --plan-only`` writes the plan;
each engine then runs every task of a fresh copy of it (``pmon.campaign.evaluate_run``; the cluster's start is
not timed), ``pmon evaluate`` merges the results into a report, and its results.json and CSVs are compared
byte for byte with the in-process run's. Printed per engine and round: wall time, the sum of the tasks' own times
(measured around the Rust call inside the worker), the overhead per task ((wall x workers - sum of task times)
/ tasks), the speed-up against 1 Dask worker of the same round, and the median task time per part.

    python python/benchmarks/evaluate.py [--source av2:../shared/data/av2/sensor/val] [--copies 4] [--smoke]
        [--rounds 2] [--pmon target/debug/pmon] [--rayon-threads 1]
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pmon import campaign

REPO = Path(__file__).resolve().parents[2]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", default=f"av2:{REPO.parent / 'shared/data/av2/sensor/val'}")
    ap.add_argument("--copies", type=int, default=4, help="links to every log under new names")
    ap.add_argument("--smoke", action="store_true", help="the smoke sweeps (default: the full ones)")
    ap.add_argument("--rounds", type=int, default=2, help="rounds of the three engines, alternating order")
    ap.add_argument("--pmon", default=str(REPO / "target" / "debug" / "pmon"))
    ap.add_argument("--rayon-threads", type=int, default=1,
                    help="RAYON_NUM_THREADS of every Dask worker (0: not set, rayon takes every core)")
    args = ap.parse_args()
    if args.rayon_threads > 0:
        # Inherited by the worker processes LocalCluster starts.
        os.environ["RAYON_NUM_THREADS"] = str(args.rayon_threads)
    scheme, path = args.source.split(":", 1) if ":" in args.source else ("", args.source)
    tmp = Path(tempfile.mkdtemp(prefix="pmon-eval-bench-"))
    src = tmp / "logs"
    src.mkdir()
    logs = [p for p in sorted(Path(path).iterdir()) if p.is_dir() and not p.name.startswith(".")]
    for k in range(args.copies):
        for p in logs:
            os.symlink(p.resolve(), src / f"{p.name}-copy{k}")
    source = f"{scheme}:{src}" if scheme else str(src)
    common = ["--seed", "7"] + (["--smoke"] if args.smoke else [])
    plan = tmp / "plan.run"
    subprocess.run([args.pmon, "evaluate", source, "--out", tmp / "plan", "--run-dir", plan, "--plan-only",
                    *common], check=True)
    tasks = json.loads((plan / "tasks.json").read_text())
    rows, reference = [], None
    engines = [("in-process, 1 thread", "threads1", 1), ("in-process, 2 threads", "threads2", 2),
               ("dask, 1 worker", "dask-local:1", 1), ("dask, 2 workers", "dask-local:2", 2)]
    loads = []
    for rnd in range(args.rounds):
        order = engines if rnd % 2 == 0 else engines[::-1]
        walls = {}
        for name, scheduler, workers in order:
            tag = scheduler.replace(":", "")
            run = tmp / f"r{rnd}-{tag}.run"
            (run / "results").mkdir(parents=True)
            shutil.copy(plan / "tasks.json", run / "tasks.json")
            out = tmp / f"r{rnd}-{tag}"
            loads.append(os.getloadavg()[0])
            busy, ran, failed, by_part, cpu_part = None, len(tasks), 0, {}, {}
            if scheduler.startswith("threads"):
                t0 = time.perf_counter()
                p = subprocess.run([args.pmon, "evaluate", source, "--out", out, "--run-dir", run, "-q",
                                    "--threads", str(workers), *common], capture_output=True, text=True)
                wall = time.perf_counter() - t0
            else:
                r = campaign.evaluate_run(run, scheduler)
                wall, ran, failed = r.wall_s, len(r.ran), len(r.failed)
                p = subprocess.run([args.pmon, "evaluate", source, "--out", out, "--run-dir", run, *common],
                                   capture_output=True, text=True)
                busy = sum(r.task_s.values())
                for ident, s in r.task_s.items():
                    by_part.setdefault(ident.rsplit("-", 1)[1], []).append(s)
                for ident, s in r.task_cpu_s.items():
                    cpu_part.setdefault(ident.rsplit("-", 1)[1], []).append(s)
            files = {f.name: f.read_bytes() for f in sorted(out.iterdir())
                     if f.name == "results.json" or f.suffix == ".csv"}
            reference = reference or files
            walls[scheduler] = wall
            rows.append({
                "round": rnd + 1, "engine": name, "tasks": ran, "failed": failed,
                "wall_s": round(wall, 2), "task_sum_s": None if busy is None else round(busy, 2),
                "overhead_ms_per_task": None if busy is None else round((wall * workers - busy) / max(ran, 1) * 1e3, 1),
                "median_task_s": {k: round(statistics.median(v), 2) for k, v in sorted(by_part.items())},
                "median_task_cpu_s": {k: round(statistics.median(v), 2) for k, v in sorted(cpu_part.items())},
                "identical": files == reference, "exit": p.returncode, "scheduler": scheduler,
            })
        for row in rows[-len(engines):]:
            base = "threads1" if row["scheduler"].startswith("threads") else "dask-local:1"
            row["speedup"] = round(walls[base] / walls[row["scheduler"]], 2)
    print(f"{len(tasks)} tasks ({len(logs)} logs x {args.copies} links x parts), {'smoke' if args.smoke else 'full'} "
          f"sweeps, pmon {args.pmon}, RAYON_NUM_THREADS per Dask worker: {os.environ.get('RAYON_NUM_THREADS', 'unset')}, "
          f"load average (1 min) at the start of each row: min {min(loads):.1f}, median {statistics.median(loads):.1f}, "
          f"max {max(loads):.1f}", file=sys.stderr)
    print("| round | engine | tasks | wall | sum of task times | overhead per task | speed-up vs 1 (thread or worker) "
          "| median task time per part | median CPU time per part | identical |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        med = ", ".join(f"{k} {v} s" for k, v in r["median_task_s"].items()) or "-"
        cpu = ", ".join(f"{k} {v} s" for k, v in r["median_task_cpu_s"].items()) or "-"
        busy = "-" if r["task_sum_s"] is None else f"{r['task_sum_s']} s"
        over = "-" if r["overhead_ms_per_task"] is None else f"{r['overhead_ms_per_task']} ms"
        print(f"| {r['round']} | {r['engine']} | {r['tasks']} | {r['wall_s']} s | {busy} | {over} | {r['speedup']} "
              f"| {med} | {cpu} | {'yes' if r['identical'] and r['exit'] == 0 else 'NO'} |")
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
