"""`pmon reproduce --scheduler`: the paper's simulated experiments (the plan of `pmon reproduce --smoke`: every
figure of --quick, fewer points), one task per run, on a Dask LocalCluster of 2 workers give the results.json, paper-vs-pmon.md and CSVs of the
single-process run byte for byte, the timing fields masked (and only those); a resumed run runs only the missing
tasks (the same result files). The progress display across the cluster: a tqdm bar on a terminal, lines otherwise, nothing when quiet."""

import io
import json
import re
import subprocess
from pathlib import Path

import pytest

from pmon import campaign

from conftest import REPRODUCE_ARGS as ARGS
from conftest import run_reproduce

# The timing fields of `pmon reproduce`'s outputs: the run's wall time, the measured latency (its number and its
# row of the claims table, verdict included); latency.csv is left out.
TIMING = [
    (r'"elapsed_s": [-+0-9.eE]+', '"elapsed_s": <timing>'),
    (r'"latency_ms": \[[^\]]*\]', '"latency_ms": <timing>'),
    # The latency claim: its numbers and its verdict (met below 12 ms; a loaded machine can miss it).
    (r'sensor checks [0-9.]+ ms, plausibility [0-9.]+ ms per frame \(median, this machine\)(",\s*"met": (true|false)'
     r'| \| (met|missed) \|)', "<latency>"),
]


def report(out):
    """The report's data files with the timing fields masked; each mask must hit where expected."""
    files = {}
    for p in sorted(Path(out).iterdir()):
        if p.name == "latency.csv" or not (p.suffix == ".csv" or p.name in ("results.json", "paper-vs-pmon.md")):
            continue
        text = p.read_text()
        for pattern, mask in TIMING:
            text, n = re.subn(pattern, mask, text)
            if p.name == "results.json":
                assert n == 1, (p.name, pattern, n)
        files[p.name] = text
    assert "results.json" in files and "paper-vs-pmon.md" in files and len(files) > 10, sorted(files)
    assert files["paper-vs-pmon.md"].count("<latency>") == 1
    return files


def reproduce(pmon_bin, tmp, out, *extra):
    return run_reproduce(pmon_bin, out, *extra)


@pytest.fixture(scope="module")
def local_report(reproduce_local):
    """The single-process run's report (masked)."""
    return report(reproduce_local)


def test_dask_gives_the_single_process_bytes_and_resumes(pmon_bin, cluster, tmp_path, local_report):
    address = cluster.scheduler_address.replace("tcp://", "dask://")
    out = tmp_path / "dask"
    p = reproduce(pmon_bin, tmp_path, out, "--scheduler", address)
    tasks = json.loads((tmp_path / "dask.run" / "tasks.json").read_text())
    n = len(tasks)
    assert n > 50 and len({t["id"] for t in tasks}) == n
    # Not a terminal: a line per finished task, naming the worker that ran it; both workers ran tasks.
    lines = [line for line in p.stderr.splitlines() if re.match(r"\[\d+/\d+\] ", line)]
    assert len(lines) == n and f"[{n}/{n}]" in p.stderr, p.stderr[-2000:]
    workers = {re.search(r" on (\S+), ", line).group(1) for line in lines}
    assert len(workers) == 2, workers
    assert report(out) == local_report
    # The claims are the local run's (the masks hid nothing else) and the figures have points.
    res = json.loads((out / "results.json").read_text())
    assert res["runs"] > 50 and len(res["figures"]) == 13 and all(f["curves"] for f in res["figures"])
    # Resume: three results deleted; the runner runs those three only and writes the same bytes again.
    results = tmp_path / "dask.run" / "results"
    before = {f.name: f.read_bytes() for f in results.iterdir()}
    for f in sorted(results.iterdir())[:3]:
        f.unlink()
    from dask.distributed import Client

    with Client(cluster) as client:
        r = campaign.evaluate_run(tmp_path / "dask.run", client)
    assert len(r.ran) == 3 and r.total == n and not r.failed
    assert {f.name: f.read_bytes() for f in results.iterdir()} == before


def test_ray_gives_the_single_process_bytes(pmon_bin, tmp_path, local_report):
    pytest.importorskip("ray", reason="ray not installed (CI does not install it; PMON_PY_RAY=1 .ci/python.sh does)")
    out = tmp_path / "ray"
    p = reproduce(pmon_bin, tmp_path, out, "--scheduler", "ray-local:2")
    n = len(json.loads((tmp_path / "ray.run" / "tasks.json").read_text()))
    assert n > 50 and f"[{n}/{n}]" in p.stderr, p.stderr[-2000:]
    assert report(out) == local_report


def test_an_unknown_scheduler_is_refused_before_anything_runs(pmon_bin, tmp_path):
    p = subprocess.run([str(pmon_bin), *ARGS, "--scheduler", "spark://x", "--out", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert p.returncode == 2 and "expected local, dask://" in p.stderr, p.stderr
    assert not (tmp_path / "o").exists()


class _Tty(io.StringIO):
    def isatty(self):
        return True


def test_progress_is_a_bar_on_a_terminal_lines_otherwise_nothing_when_quiet():
    pytest.importorskip("tqdm")
    tty = _Tty()
    bar = campaign._Progress(False, tty)
    bar.start(2, 5)  # two tasks finished before this run
    bar(3, 5, "a", "host:1", 0.1)
    bar(4, 5, "b", "host:2", 0.1, failed=True)
    bar.close()
    text = tty.getvalue()
    assert "4/5" in text and "failed=1" in text and "FAILED b on host:2" in text, text
    log = io.StringIO()
    lines = campaign._Progress(False, log)
    lines.start(0, 2)
    lines(1, 2, "a", "host:1", 0.5)
    lines(2, 2, "b", "host:1", 0.5, failed=True)
    assert log.getvalue() == "[1/2] a on host:1, 0.5 s\n[2/2] b on host:1, 0.5 s, FAILED\n"
    quiet_tty = _Tty()
    quiet = campaign._Progress(True, quiet_tty)
    quiet.start(0, 2)
    quiet(1, 2, "a", "host:1", 0.5, failed=True)
    quiet.close()
    assert quiet_tty.getvalue() == ""
