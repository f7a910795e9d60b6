"""Campaigns split into independent tasks, run in-process, on Dask or on Ray, merged to the same bytes.

A *task* is one run of the monitor over one scene with one fault setting and one set of parameters: the Rust
extension simulates the scene, injects the fault, checks every frame and scores the run
(``pmon_campaign::run_one``, the code of ``pmon reproduce``), and returns counts (injected, detected, alarms,
true alarms, states in scope, ...), never rates. Merging adds integers: exact, associative, and the same in any
order. Tasks are seeded by their identity: the injection seed is a hash of the campaign seed and the task's
canonical description, never its position in the plan or the worker that runs it.

>>> from pmon import campaign
>>> tasks = campaign.plan(["pedestrians"], scene_seeds=[7], duration_s=1.0,
...                       faults=[{"kind": "permanent_position", "magnitude_m": 1.0, "direction": "away"}])
>>> result = campaign.run(tasks)                      # in-process; or run(tasks, client) with a Dask client
>>> result.totals["sensor"]["injected"] > 0
True

See ``docs/campaigns.md`` ("Sharded campaigns") in the repository.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import time
from dataclasses import dataclass, field
from itertools import product
from typing import Any, Callable, Iterable, Iterator, Mapping, Optional, Sequence

from ._params import Params
from ._pmon import run_campaign_task

__all__ = ["CampaignResult", "EvaluationRun", "evaluate_run", "plan", "run", "run_task", "merge", "task_id"]

FORMAT = "pmon-campaign/1"

# The keys of a task description that identify the *setting* (summed over scenes and seeds in `groups`).
_SCENE_KEYS = ("scenario", "scene_seed", "duration_s")


def _canonical(value: Any) -> str:
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)


def task_id(task: Mapping[str, Any]) -> str:
    """The identity of a task: its description as canonical JSON (sorted keys, no spaces)."""
    return _canonical(dict(task))


def _seed_of(campaign_seed: int, ident: str) -> int:
    digest = hashlib.blake2b(f"{campaign_seed}\n{ident}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little")


def plan(
    scenarios: Sequence[str],
    *,
    faults: Sequence[Mapping[str, Any]],
    scene_seeds: Sequence[int] = (1,),
    params: Sequence[Mapping[str, Any] | Params | None] = (None,),
    duration_s: float | None = None,
    position_noise_m: float = 0.0,
    permanent_track_fraction: float = 0.5,
    window: int = 2,
    seed: int = 1,
) -> list[dict[str, Any]]:
    """Every combination of scenario x scene seed x fault x parameter set, as task descriptions.

    ``faults`` are the fault settings of ``pmon reproduce`` as JSON objects, e.g. ``{"kind": "none"}``,
    ``{"kind": "permanent_position", "magnitude_m": 1.0, "direction": "away"}`` (or ``towards``, ``random``),
    ``{"kind": "random_position", "magnitude_m": 1.0, "rate": 0.1, "direction": "random"}``,
    ``{"kind": "permanent_speed", "magnitude_mps": 2.0}``, ``{"kind": "transient_speed", "magnitude_mps": 2.0,
    "rate": 0.1}``. ``params`` are overrides of the defaults (a dict with any subset of keys, or a
    :class:`pmon.Params`, whose non-default values are kept). Each task gets ``injection_seed`` derived from
    ``seed`` and the rest of its description. The list is sorted by task identity.
    """
    if not scenarios or not faults or not scene_seeds or not params:
        raise ValueError("plan: scenarios, faults, scene_seeds and params must not be empty")
    defaults = Params().to_dict()
    tasks: dict[str, dict[str, Any]] = {}
    for scenario, scene_seed, fault, p in product(scenarios, scene_seeds, faults, params):
        if isinstance(p, Params):
            p = {k: v for k, v in p.to_dict().items() if defaults.get(k) != v}
        elif p is not None:
            Params(**p)  # validated now, by the Rust side, rather than on a worker later
        desc: dict[str, Any] = {
            "scenario": str(scenario),
            "scene_seed": int(scene_seed),
            "fault": dict(fault),
            "params": dict(p) if p else None,
            "position_noise_m": float(position_noise_m),
            "permanent_track_fraction": float(permanent_track_fraction),
            "window": int(window),
        }
        if duration_s is not None:
            desc["duration_s"] = float(duration_s)
        ident = task_id(desc)
        if ident in tasks:
            raise ValueError(f"plan: duplicate task {ident}")
        desc["injection_seed"] = _seed_of(seed, ident)
        tasks[ident] = desc
    return [tasks[k] for k in sorted(tasks)]


def run_task(task: Mapping[str, Any]) -> dict[str, Any]:
    """Runs one task in this process (the Rust extension, without the GIL).

    Returns ``{"id", "task", "metrics"}`` (counts), or ``{"id", "task", "error"}`` when the task is refused
    (unknown scenario, parameters out of range): a failing task is reported, it does not stop the campaign.
    ``elapsed_s`` (wall time) and ``worker`` are informative and never written to the results file.
    """
    task = dict(task)
    ident = task_id(task)
    t0 = time.perf_counter()
    out: dict[str, Any] = {"id": ident, "task": task}
    try:
        out["metrics"] = json.loads(run_campaign_task(_canonical(task)))["metrics"]
    except ValueError as e:
        out["error"] = str(e)
    out["elapsed_s"] = time.perf_counter() - t0
    out["worker"] = os.getpid()
    return out


def _add(a: Any, b: Any) -> Any:
    if isinstance(a, dict):
        if a.keys() != b.keys():
            raise ValueError(f"merge: results with different fields: {sorted(a)} vs {sorted(b)}")
        return {k: _add(a[k], b[k]) for k in a}
    if isinstance(a, int) and isinstance(b, int):
        return a + b
    raise ValueError(f"merge: not a count: {a!r}")


def merge(results: Iterable[Mapping[str, Any]]) -> dict[str, Any]:
    """The merged, timing-free content of a campaign: per task (sorted by identity), per setting (summed over
    scenes and seeds) and in total. Only integers are added, so any order and any grouping of the same task
    results give the same dict. A task id seen twice is an error (a result would be counted twice)."""
    by_id: dict[str, Mapping[str, Any]] = {}
    for r in results:
        if r["id"] in by_id:
            raise ValueError(f"merge: task {r['id']} reported twice")
        by_id[r["id"]] = r
    tasks, failed = [], []
    groups: dict[str, dict[str, Any]] = {}
    total: dict[str, Any] | None = None
    for ident in sorted(by_id):
        r = by_id[ident]
        if "error" in r:
            failed.append({"id": ident, "task": r["task"], "error": r["error"]})
            continue
        m = r["metrics"]
        tasks.append({"id": ident, "task": r["task"], "metrics": m})
        setting = {k: v for k, v in r["task"].items() if k not in _SCENE_KEYS and k != "injection_seed"}
        gid = _canonical(setting)
        g = groups.get(gid)
        groups[gid] = {"setting": setting, "tasks": 1, "metrics": m} if g is None else {
            "setting": setting, "tasks": g["tasks"] + 1, "metrics": _add(g["metrics"], m)}
        total = m if total is None else _add(total, m)
    return {
        "format": FORMAT,
        "tasks": tasks,
        "failed": failed,
        "settings": [groups[k] for k in sorted(groups)],
        "total": total,
    }


@dataclass
class CampaignResult:
    """A merged campaign: ``content`` is what :meth:`write` saves; timings are kept apart."""

    content: dict[str, Any]
    engine: str
    workers: int
    wall_s: float
    task_s: list[float] = field(default_factory=list)
    worker_pids: list[int] = field(default_factory=list)

    @property
    def totals(self) -> dict[str, Any]:
        """The counts summed over every task that succeeded."""
        return self.content["total"]

    @property
    def failed(self) -> list[dict[str, Any]]:
        """Tasks refused by the Rust side, with their error."""
        return self.content["failed"]

    def to_json(self) -> str:
        """The results file's text: sorted keys, two-space indent, a final newline. No timing fields."""
        return json.dumps(self.content, sort_keys=True, indent=2, allow_nan=False) + "\n"

    def write(self, path: str | os.PathLike[str]) -> None:
        """Writes :meth:`to_json` to ``path``; an existing file is never overwritten (``FileExistsError``)."""
        with open(path, "x", encoding="utf-8", newline="\n") as f:
            f.write(self.to_json())


def run(
    tasks: Sequence[Mapping[str, Any]],
    engine: Any = "local",
    progress: Optional[Callable[[int, int], None]] = None,
) -> CampaignResult:
    """Runs the tasks and merges their results.

    ``engine``: ``"local"`` (this process, one task after the other), a ``dask.distributed.Client`` (each task
    a Dask task keyed by its identity; tasks lost with a worker are rerun by Dask's scheduler), or ``"ray"``
    (``ray.remote`` on the cluster ``ray.init`` connected to). The content is the same for every engine.
    ``progress(done, total)`` is called in this thread after every finished task.
    """
    tasks = [dict(t) for t in tasks]
    total = len(tasks)
    results: list[dict[str, Any]] = []

    def done(r: dict[str, Any]) -> None:
        results.append(r)
        if progress is not None:
            progress(len(results), total)

    t0 = time.perf_counter()
    if isinstance(engine, str) and engine == "local":
        for t in tasks:
            done(run_task(t))
        name, workers = "local", 1
    elif isinstance(engine, str) and engine == "ray":
        import ray  # optional

        remote = ray.remote(run_task)
        pending = [remote.remote(t) for t in tasks]
        while pending:
            ready, pending = ray.wait(pending)
            for r in ray.get(ready):
                done(r)
        name, workers = "ray", int(ray.cluster_resources().get("CPU", 0))
    elif hasattr(engine, "map") and hasattr(engine, "gather"):
        from dask.distributed import as_completed

        keys = ["pmon-task-" + hashlib.blake2b(task_id(t).encode(), digest_size=16).hexdigest() for t in tasks]
        futures = engine.map(run_task, tasks, key=keys, pure=False, retries=2)
        for fut in as_completed(futures):
            done(fut.result())
            fut.release()
        name, workers = "dask", len(engine.scheduler_info()["workers"])
    else:
        raise ValueError(f"run: unknown engine {engine!r} (\"local\", \"ray\" or a dask.distributed.Client)")
    wall = time.perf_counter() - t0
    return CampaignResult(
        merge(results),
        name,
        workers,
        wall,
        [r["elapsed_s"] for r in results],
        sorted({r["worker"] for r in results}),
    )


# ---------------------------------------------------------------------------------------------------------------
# Run folders of `pmon evaluate` and `pmon reproduce --scheduler` (docs/campaigns.md)
# ---------------------------------------------------------------------------------------------------------------


def _run_task_json(task_json: str) -> tuple[str, float, int, str, float]:
    """Runs one task of a run folder in this process: (result JSON, seconds, pid, host, CPU seconds of the
    process meanwhile). A `pmon reproduce` task (format ``pmon-reproduce-task/1``: one run of the paper's plan on
    a built-in scene) or a `pmon evaluate` task (one log and part). The result holds no timing; an error on the
    task's data is inside the result, not raised."""
    import socket

    # absolute: also when this file runs as __main__
    from pmon._pmon import run_evaluation_task, run_reproduce_task

    t0, c0 = time.perf_counter(), time.process_time()
    if json.loads(task_json).get("format", "").startswith("pmon-reproduce-task/"):
        text = run_reproduce_task(task_json)
    else:
        text = run_evaluation_task(task_json)
    return text, time.perf_counter() - t0, os.getpid(), socket.gethostname(), time.process_time() - c0


# The name the first version shipped to workers under.
_evaluate_task = _run_task_json


# Tasks submitted to Dask or Ray ahead of the finished ones (at least twice the cluster's threads): the
# scheduler holds that many payloads, not the whole plan's.
_WINDOW = 64


def _payload(run_dir: str, task: Mapping[str, Any]) -> str:
    """The task as shipped to a worker: with the text of its nuScenes v1.0 scene slice (``tables``, a file in the
    run folder written by ``pmon evaluate``) as ``scene_tables``. A slice file that is gone leaves the task as it
    is: it then reads the dataset's table folder, with the same results."""
    rel = task.get("tables")
    if rel:
        try:
            with open(os.path.join(run_dir, rel), encoding="utf-8", newline="") as f:
                return json.dumps({**task, "scene_tables": f.read()})
        except OSError:
            pass
    return json.dumps(task)


def _write_atomic(path: str, text: str) -> None:
    tmp = f"{path}.tmp-{os.getpid()}"
    with open(tmp, "w", encoding="utf-8", newline="\n") as f:
        f.write(text)
    os.replace(tmp, path)


def _finished(path: str) -> bool:
    try:
        with open(path, encoding="utf-8") as f:
            return "ok" in json.load(f)["outcome"]
    except (OSError, ValueError, KeyError, TypeError):
        return False


@dataclass
class EvaluationRun:
    """What :func:`evaluate_run` did: the tasks it ran (the others had a result already) and their timings."""

    total: int
    ran: list[str]
    failed: list[str]
    wall_s: float
    task_s: dict[str, float] = field(default_factory=dict)
    task_cpu_s: dict[str, float] = field(default_factory=dict)
    workers: list[str] = field(default_factory=list)


def _engine(scheduler: Any) -> tuple[Any, Callable[[], None]]:
    """A scheduler string (``local``, ``dask://HOST:PORT``, ``dask-local:N``, ``ray``, ``ray://HOST:PORT``,
    ``ray-local:N``) as an engine for :func:`evaluate_run`, and what closes it. Other values pass through."""
    if not isinstance(scheduler, str):
        return scheduler, lambda: None
    if scheduler == "local":
        return "local", lambda: None
    if scheduler.startswith("dask://") or scheduler.startswith("dask-local:"):
        from dask.distributed import Client, LocalCluster

        if scheduler.startswith("dask://"):
            client = Client("tcp://" + scheduler[len("dask://"):])
            return client, client.close
        cluster = LocalCluster(n_workers=int(scheduler.split(":", 1)[1]), threads_per_worker=1,
                               dashboard_address=None)
        client = Client(cluster)

        def close() -> None:
            client.close()
            cluster.close()

        return client, close
    if scheduler == "ray" or scheduler.startswith("ray://") or scheduler.startswith("ray-local:"):
        try:
            import ray
        except ImportError as e:
            raise RuntimeError(f"--scheduler {scheduler}: ray is not installed (pip install ray)") from e
        if scheduler.startswith("ray-local:"):
            ray.init(num_cpus=int(scheduler.split(":", 1)[1]), include_dashboard=False)
        elif scheduler == "ray":
            ray.init()
        else:
            ray.init(scheduler)
        return "ray", ray.shutdown
    raise ValueError(f"unknown scheduler {scheduler!r}: local, dask://HOST:PORT, dask-local:N, ray, ray://HOST:PORT, "
                     "ray-local:N")


def evaluate_run(run_dir: str | os.PathLike[str], engine: Any = "local",
                 progress: Optional[Callable[[int, int, str, str, float], None]] = None) -> EvaluationRun:
    """Runs the tasks of a run folder that have no finished result yet: one of `pmon evaluate` (a task per log
    and part) or of `pmon reproduce --scheduler ...` (a task per run of the paper's plan).

    ``run_dir`` holds ``tasks.json`` (written by ``pmon evaluate`` or ``pmon reproduce``) and ``results/``; each finished task's result
    (the Rust side's JSON, byte for byte) is written to ``results/ID.json`` as it arrives, through a temporary
    file and a rename, so a run that stops keeps what finished and a rerun runs only the rest. Tasks whose
    result is an error are run again. ``engine``: ``"local"``, a ``dask.distributed.Client``, ``"ray"`` (after
    ``ray.init``) or a scheduler string (see :func:`_engine`). ``progress(done, total, task id, where, seconds)``
    is called after every finished task. ``pmon evaluate`` / ``pmon reproduce`` merge the results and write the report.
    """
    run_dir = os.fspath(run_dir)
    with open(os.path.join(run_dir, "tasks.json"), encoding="utf-8") as f:
        tasks = json.load(f)
    results = os.path.join(run_dir, "results")
    os.makedirs(results, exist_ok=True)
    todo = [t for t in tasks if not _finished(os.path.join(results, f"{t['id']}.json"))]
    out = EvaluationRun(total=len(tasks), ran=[], failed=[], wall_s=0.0)
    engine, close = _engine(engine)
    t0 = time.perf_counter()

    def done(ident: str, r: tuple[str, float, int, str, float]) -> None:
        text, seconds, pid, host, cpu = r
        _write_atomic(os.path.join(results, f"{ident}.json"), text)
        out.ran.append(ident)
        out.task_s[ident] = seconds
        out.task_cpu_s[ident] = cpu
        where = f"{host}:{pid}"
        if where not in out.workers:
            out.workers.append(where)
        if "error" in json.loads(text)["outcome"]:
            out.failed.append(ident)
        if progress is not None:
            progress(len(tasks) - len(todo) + len(out.ran), len(tasks), ident, where, seconds)

    def payloads() -> Iterator[tuple[str, str]]:
        # Made as they are submitted: a nuScenes v1.0 task carries its scene's slice of the tables (read from the
        # run folder, so the workers need not see it), up to a few MB each.
        for t in todo:
            yield t["id"], _payload(run_dir, t)

    try:
        if engine == "local":
            for ident, p in payloads():
                done(ident, _run_task_json(p))
        elif engine == "ray":
            import ray

            remote = ray.remote(max_retries=2)(_run_task_json)
            window = max(_WINDOW, 2 * int(ray.available_resources().get("CPU", 1)))
            queue = payloads()
            pending: dict[Any, str] = {}
            while True:
                for ident, p in itertools.islice(queue, window - len(pending)):
                    pending[remote.remote(p)] = ident
                if not pending:
                    break
                ready, _ = ray.wait(list(pending))
                for ref in ready:
                    done(pending.pop(ref), ray.get(ref))
        elif hasattr(engine, "submit"):
            from dask.distributed import as_completed

            window = max(_WINDOW, 2 * sum(engine.nthreads().values()))
            queue = payloads()

            def submit(ident: str, p: str) -> Any:
                fut = engine.submit(_run_task_json, p, key="pmon-task-" + hashlib.blake2b(
                    p.encode(), digest_size=16).hexdigest(), pure=False, retries=2)
                futures[fut] = ident
                return fut

            futures: dict[Any, str] = {}
            running = as_completed([submit(i, p) for i, p in itertools.islice(queue, window)])
            for fut in running:
                done(futures.pop(fut), fut.result())
                fut.release()
                for ident, p in itertools.islice(queue, 1):
                    running.add(submit(ident, p))
        else:
            raise ValueError(f"evaluate_run: unknown engine {engine!r}")
    finally:
        out.wall_s = time.perf_counter() - t0
        close()
    return out


class _Progress:
    """What ``python -m pmon.campaign run`` shows: a bar across the cluster (tasks done / total, failures, ETA;
    tqdm) on a terminal, a line per finished task (with the worker that ran it) otherwise, nothing with
    ``--quiet``."""

    def __init__(self, quiet: bool, stream: Any = None) -> None:
        import sys

        self.stream = stream if stream is not None else sys.stderr
        self.quiet = quiet
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.bar: Any = None
        self.failed = 0

    def start(self, done: int, total: int) -> None:
        """Before the first task: ``done`` of ``total`` finished before this run."""
        if self.tty and not self.quiet:
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=done, unit="task", file=self.stream, dynamic_ncols=True,
                            smoothing=0.1, desc="pmon tasks")
            self.bar.set_postfix(failed=0)

    def __call__(self, done: int, total: int, ident: str, where: str, seconds: float, failed: bool = False) -> None:
        if self.quiet:
            return
        self.failed += int(failed)
        if self.bar is not None:
            if failed:
                self.bar.write(f"FAILED {ident} on {where}", file=self.stream)
            self.bar.set_postfix(failed=self.failed, refresh=False)
            self.bar.update(1)
        else:
            status = ", FAILED" if failed else ""
            print(f"[{done}/{total}] {ident} on {where}, {seconds:.1f} s{status}", file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _main(argv: Optional[Sequence[str]] = None) -> int:
    import argparse
    import sys

    ap = argparse.ArgumentParser(prog="python -m pmon.campaign", description=(
        "Runs the missing tasks of a run folder of `pmon evaluate` or `pmon reproduce --scheduler` on a scheduler "
        "(those commands call this; then they merge the results and write the report)."))
    sub = ap.add_subparsers(dest="command", required=True)
    ev = sub.add_parser("run", aliases=["evaluate-run"], help="run the unfinished tasks of RUN_DIR")
    ev.add_argument("run_dir")
    ev.add_argument("--scheduler", default="local",
                    help="local, dask://HOST:PORT, dask-local:N, ray, ray://HOST:PORT or ray-local:N")
    ev.add_argument("--quiet", "-q", action="store_true", help="no progress bar or lines")
    args = ap.parse_args(argv)
    show = _Progress(args.quiet)
    results = os.path.join(args.run_dir, "results")
    try:
        with open(os.path.join(args.run_dir, "tasks.json"), encoding="utf-8") as f:
            ids = [t["id"] for t in json.load(f)]
        show.start(sum(_finished(os.path.join(results, f"{i}.json")) for i in ids), len(ids))
    except (OSError, ValueError, KeyError, TypeError):
        pass  # evaluate_run says what is wrong with the folder

    def progress(k: int, n: int, ident: str, where: str, seconds: float) -> None:
        # evaluate_run has written the task's result when it calls this: a failure is read from it.
        failed = not _finished(os.path.join(results, f"{ident}.json"))
        show(k, n, ident, where, seconds, failed)

    try:
        r = evaluate_run(args.run_dir, args.scheduler, progress=progress)
    finally:
        show.close()
    if not args.quiet:
        print(f"pmon.campaign: ran {len(r.ran)} of {r.total} tasks in {r.wall_s:.1f} s on {len(r.workers)} worker "
              f"processes; {len(r.failed)} failed on their data", file=sys.stderr)
    return 0


if __name__ == "__main__":
    # `python -m pmon.campaign`: run the package's module, so that the task function Dask and Ray ship is
    # `pmon.campaign._evaluate_task` (pickled by reference), not a copy from __main__.
    from pmon.campaign import _main as _package_main

    raise SystemExit(_package_main())
