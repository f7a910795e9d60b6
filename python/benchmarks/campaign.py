"""Cost of pmon.campaign per task, in-process and on a Dask LocalCluster of 1 and 2 workers, in one run.

For each engine the same plan runs twice (the first run simulates the scenes in every worker process, the
second finds them in the process's cache) and prints: wall time, the sum of the tasks' own times (measured
inside each task, around the Rust call), the overhead per task ((wall x workers - sum of task times) / tasks),
and whether the results file is byte-identical to the in-process one.

    python python/benchmarks/campaign.py [--seeds 4] [--duration-s 2]
"""

import argparse
import json

from dask.distributed import Client, LocalCluster

from pmon import campaign


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=4, help="scene seeds per scenario")
    ap.add_argument("--duration-s", type=float, default=2.0, help="length of each simulated scene")
    ap.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = ap.parse_args()
    faults = [
        {"kind": "none"},
        {"kind": "permanent_position", "magnitude_m": 1.0, "direction": "away"},
        {"kind": "random_position", "magnitude_m": 1.5, "rate": 0.2, "direction": "random"},
        {"kind": "transient_speed", "magnitude_mps": 3.0, "rate": 0.2},
    ]
    tasks = campaign.plan(["pedestrians", "intersection"], scene_seeds=range(1, args.seeds + 1), faults=faults,
                          duration_s=args.duration_s, position_noise_m=0.1)
    rows = []
    reference = None

    def measure(name, engine, workers):
        nonlocal reference
        for attempt in ("cold", "warm"):
            r = campaign.run(tasks, engine)
            reference = reference or r.to_json()
            busy = sum(r.task_s)
            rows.append({
                "engine": name, "run": attempt, "tasks": len(tasks), "wall_s": round(r.wall_s, 3),
                "task_sum_s": round(busy, 3),
                "overhead_ms_per_task": round((r.wall_s * workers - busy) / len(tasks) * 1e3, 1),
                "identical": r.to_json() == reference,
            })

    measure("local", "local", 1)
    for n in (1, 2):
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None) as cl, \
                Client(cl) as client:
            measure(f"dask {n} worker{'s' if n > 1 else ''}", client, n)
    if args.json:
        print(json.dumps(rows, indent=2))
        return
    print(f"{len(tasks)} tasks ({args.duration_s} s scenes)")
    print(f"{'engine':<16}{'run':<6}{'wall s':>9}{'task sum s':>12}{'overhead ms/task':>18}  identical")
    for r in rows:
        print(f"{r['engine']:<16}{r['run']:<6}{r['wall_s']:>9.2f}{r['task_sum_s']:>12.2f}"
              f"{r['overhead_ms_per_task']:>18.1f}  {r['identical']}")


if __name__ == "__main__":
    main()
