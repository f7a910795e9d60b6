"""Overhead per task and 1 vs. 2 Dask workers for the tasks of `pmon reproduce --scheduler` (the paper's plan, one
task per run), side by side in one run (docs/campaigns.md).

The plan is made once by `pmon reproduce ... --scheduler local`-equivalent planning: a first `pmon reproduce
--scheduler dask-local:1` run writes the run folder (tasks.json). Then the same tasks run in this process, on a
1-worker and on a 2-worker LocalCluster, twice each (cold: the worker simulates the scenes; warm: they are in its
cache), each into a fresh copy of the run folder, and every result file is compared with the in-process one.
Overhead per task = (wall x workers - sum of the tasks' own times) / tasks. The cluster's start is not timed.

    python python/benchmarks/reproduce.py --pmon target/debug/pmon [--duration-s 1] [--scale quick|smoke]
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from pmon import campaign


def results(run):
    return {p.name: p.read_bytes() for p in sorted((Path(run) / "results").iterdir())}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--pmon", default="target/debug/pmon")
    ap.add_argument("--duration-s", default="1")
    ap.add_argument("--scale", choices=["quick", "smoke"], default="quick")
    ap.add_argument("--seed", default="5")
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="pmon-repro-bench-"))
    base = tmp / "plan.run"
    p = subprocess.run([a.pmon, "reproduce", f"--{a.scale}", "--duration-s", a.duration_s, "--seed", a.seed,
                        "--data", str(tmp / "none"), "--out", str(tmp / "first"), "--run-dir", str(base),
                        "--scheduler", "dask-local:1", "--python", sys.executable, "--quiet"],
                       capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(p.stderr)
    n = len(list((base / "results").iterdir()))
    print(f"{n} tasks ({a.scale} plan, {a.duration_s} s scenes), load average {os.getloadavg()[0]:.1f}")
    from dask.distributed import Client, LocalCluster

    reference = None
    rows = []
    for name, workers in [("in-process", 1), ("Dask, 1 worker", 1), ("Dask, 2 workers", 2)]:
        cluster = client = None
        if name != "in-process":
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=None)
            client = Client(cluster)
        try:
            for rnd in ["cold", "warm"]:
                run = tmp / f"{name.replace(' ', '').replace(',', '')}-{rnd}.run"
                shutil.copytree(base, run)
                shutil.rmtree(run / "results")
                r = campaign.evaluate_run(run, client if client is not None else "local")
                got = results(run)
                reference = reference or got
                task_sum = sum(r.task_s.values())
                over = (r.wall_s * workers - task_sum) / len(r.ran)
                med = statistics.median(r.task_s.values())
                rows.append((name, rnd, r.wall_s, task_sum, over, med, got == reference and len(got) == n))
        finally:
            if client is not None:
                client.close()
                cluster.close()
    print("| engine | run | wall | sum of task times | overhead per task | median task | identical |")
    print("|---|---|---|---|---|---|---|")
    for name, rnd, wall, task_sum, over, med, same in rows:
        print(f"| {name} | {rnd} | {wall:.2f} s | {task_sum:.2f} s | {1000 * over:.1f} ms | {1000 * med:.0f} ms | "
              f"{'yes' if same else 'NO'} |")
    warm = {name: wall for name, rnd, wall, *_ in rows if rnd == "warm"}
    print(f"speed-up, warm, 2 workers vs. 1: {warm['Dask, 1 worker'] / warm['Dask, 2 workers']:.2f}")
    print(f"load average at the end {os.getloadavg()[0]:.1f}")
    shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
