"""`pmon evaluate` on a scheduler: the tasks of a run folder run on a Dask LocalCluster (2 workers; and again
with a worker killed mid-run) or on Ray give report files byte-identical to `--scheduler local`; a resumed run
(some results deleted) runs only those and gives the same bytes; a broken recording is reported by name."""

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from pmon import campaign


def _run(cmd, **kw):
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kw)


@pytest.fixture(scope="module")
def recordings(pmon_bin, tmp_path_factory):
    root = tmp_path_factory.mktemp("eval") / "recs"
    for name, scenario, seed in [("a-street", "pedestrians", 3), ("b-crossing", "intersection", 4),
                                 ("c-street", "pedestrians", 5)]:
        p = _run([pmon_bin, "simulate", "--scenario", scenario, "--seed", seed, "--duration-s", "2",
                  "--out", root / name])
        assert p.returncode == 0, p.stderr
    broken = root / "d-broken"
    broken.mkdir()
    shutil.copy(root / "a-street" / "recording.json", broken / "recording.json")
    (broken / "frames.jsonl").write_text('{"not": json\n')
    return root


def evaluate(pmon_bin, src, out, *extra, **kw):
    return _run([pmon_bin, "evaluate", src, "--smoke", "--seed", "3", "--out", out, "--python", sys.executable,
                 *extra], **kw)


def report_bytes(out):
    return {p.name: p.read_bytes() for p in sorted(Path(out).iterdir())
            if p.name == "results.json" or p.suffix == ".csv"}


@pytest.fixture(scope="module")
def local_report(pmon_bin, recordings, tmp_path_factory):
    out = tmp_path_factory.mktemp("local") / "report"
    p = evaluate(pmon_bin, recordings, out, "--scheduler", "local", "--threads", "1")
    assert p.returncode == 1, p.stderr  # the broken recording
    res = json.loads((out / "results.json").read_text())
    assert len(res["tasks"]) == 8 and [f["log"] for f in res["failed"]] == ["d-broken", "d-broken"]
    assert "frames.jsonl" in res["failed"][0]["error"]
    return out


def test_dask_scheduler_gives_the_local_bytes_and_resumes(pmon_bin, recordings, local_report, cluster, tmp_path):
    address = cluster.scheduler_address.replace("tcp://", "dask://")
    out = tmp_path / "dask"
    p = evaluate(pmon_bin, recordings, out, "--scheduler", address)
    assert p.returncode == 1, p.stderr
    assert "[8/8]" in p.stderr, p.stderr  # progress, task by task, with the worker that ran it
    assert report_bytes(out) == report_bytes(local_report)
    # Resume: two finished results deleted; the rerun runs them (and the two failed ones) only.
    results = tmp_path / "dask.run" / "results"
    for name in ["recording-b-crossing-sensor.json", "recording-c-street-tracks.json"]:
        (results / name).unlink()
    p = evaluate(pmon_bin, recordings, out, "--scheduler", address)
    assert "4 finished in" in p.stderr and "4 to run" in p.stderr, p.stderr
    assert "ran 4 of 8 tasks" in p.stderr, p.stderr
    assert report_bytes(out) == report_bytes(local_report)


def test_a_killed_worker_changes_nothing(pmon_bin, recordings, local_report, cluster, tmp_path):
    from dask.distributed import Client

    # The plan and the local results are copied; the results of every working recording are deleted, so the
    # cluster runs 6 tasks; a worker busy with one is killed after the first result arrives.
    run = tmp_path / "k.run"
    shutil.copytree(str(local_report) + ".run", run)
    for f in (run / "results").iterdir():
        if "d-broken" not in f.name:
            f.unlink()
    with Client(cluster) as client:
        killed = []

        def kill_one(done, total, ident, where, seconds):
            if not killed:
                busy = [w for w, tasks in client.processing().items() if tasks]
                pids = client.run(os.getpid, workers=busy[:1])
                for pid in pids.values():
                    os.kill(pid, signal.SIGKILL)
                    killed.append(pid)

        r = campaign.evaluate_run(run, client, progress=kill_one)
    assert killed, "no worker was busy"
    assert len(r.ran) >= 6
    out = tmp_path / "k"
    p = evaluate(pmon_bin, recordings, out, "--run-dir", run, "--scheduler", "local")
    assert "6 finished in" in p.stderr and "2 to run" in p.stderr, p.stderr  # only the broken log's two
    assert report_bytes(out) == report_bytes(local_report)


def test_ray_scheduler_gives_the_local_bytes(pmon_bin, recordings, local_report, tmp_path):
    try:
        import ray  # noqa: F401
    except ImportError:
        pytest.skip("ray is not installed (pip install ray): the Ray scheduler is not tested here")
    out = tmp_path / "ray"
    p = evaluate(pmon_bin, recordings, out, "--scheduler", "ray-local:2", timeout=600)
    assert p.returncode == 1, p.stderr
    assert report_bytes(out) == report_bytes(local_report)


@pytest.fixture(scope="module")
def nuscenes_tables(tmp_path_factory):
    """Generated nuScenes v1.0 tables of 3 scenes with small sweeps (python/benchmarks/nuscenes_tables.py)."""
    root = tmp_path_factory.mktemp("nus") / "data"
    gen = Path(__file__).resolve().parents[1] / "benchmarks" / "nuscenes_tables.py"
    p = _run([sys.executable, gen, root, "--scenes", "3", "--samples", "6", "--annotations", "8", "--instances",
              "6", "--points", "3000"])
    assert p.returncode == 0, p.stderr
    return root


def test_nuscenes_scenes_run_on_their_table_slices(pmon_bin, nuscenes_tables, cluster, tmp_path):
    """The tables are cut once into a slice per scene (in the run folder); the tasks carry their slice to the
    workers. Locally, on Dask, and without slices (each task reading the whole tables, as before) the report
    bytes are the same."""
    src = f"nuscenes:{nuscenes_tables}"
    local = tmp_path / "local"
    p = evaluate(pmon_bin, src, local, "--scheduler", "local", "--threads", "1")
    assert p.returncode == 0, p.stderr
    assert "cut into 3 scene slices" in p.stderr, p.stderr
    slices = sorted((tmp_path / "local.run" / "tables").iterdir())
    assert [s.name for s in slices] == ["scene-0001.json", "scene-0002.json", "scene-0003.json"]
    first = json.loads(slices[0].read_text())
    # its own 6 samples, their 6 LIDAR_TOP keyframes (of 6 x 78 sample_data rows), their annotations
    assert len(first["sample.json"]) == 6 and len(first["sample_data.json"]) == 6
    assert len(first["ego_pose.json"]) == 6 and len(first["sample_annotation.json"]) == 6 * 8
    tasks = json.loads((tmp_path / "local.run" / "tasks.json").read_text())
    assert sorted(t["tables"] for t in tasks) == sorted(2 * [f"tables/{s.name}" for s in slices])
    assert not any("scene_tables" in t for t in tasks), "the slices' text is shipped, never planned"
    res = json.loads((local / "results.json").read_text())
    assert not res["failed"] and sum(t["frames"] for t in res["tasks"]) == 2 * 3 * 6

    address = cluster.scheduler_address.replace("tcp://", "dask://")
    p = evaluate(pmon_bin, src, tmp_path / "dask", "--scheduler", address)
    assert p.returncode == 0, p.stderr
    assert report_bytes(tmp_path / "dask") == report_bytes(local)

    # Without the slices: planned, the slices removed, the tasks run in-process from the bare plan (each reads the
    # table folder), then merged.
    run = tmp_path / "bare.run"
    p = evaluate(pmon_bin, src, tmp_path / "bare", "--run-dir", run, "--plan-only")
    assert p.returncode == 0, p.stderr
    shutil.rmtree(run / "tables")
    r = campaign.evaluate_run(run, "local")
    assert len(r.ran) == 6 and not r.failed
    p = evaluate(pmon_bin, src, tmp_path / "bare", "--run-dir", run, "--scheduler", "local")
    assert p.returncode == 0 and "0 to run" in p.stderr, p.stderr
    assert "scene slices" not in p.stderr and not (run / "tables").exists(), "nothing to run: nothing cut"
    assert report_bytes(tmp_path / "bare") == report_bytes(local)
