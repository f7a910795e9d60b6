"""Shared fixtures: the `pmon` command (the oracle), a simulated recording, the real data extracts."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _pmon_bin():
    explicit = os.environ.get("PMON_BIN")
    if explicit:
        return Path(explicit)
    for profile in ("debug", "release"):
        p = REPO / "target" / profile / "pmon"
        if p.is_file():
            return p
    found = shutil.which("pmon")
    return Path(found) if found else None


@pytest.fixture(scope="session")
def pmon_bin():
    """The `pmon` command, the independent side of the comparisons (PMON_BIN, else target/debug/pmon)."""
    p = _pmon_bin()
    if p is None or not p.is_file():
        pytest.skip("the pmon command is not built (cargo build -p pmon, or set PMON_BIN)")
    return p


@pytest.fixture(scope="session")
def data_dir():
    """The real data extracts (PMON_DATA_DIR, else ../shared/data beside the repository)."""
    return Path(os.environ.get("PMON_DATA_DIR", REPO.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def sim_recording(pmon_bin, tmp_path_factory):
    """`pmon simulate --scenario pedestrians --seed 7 --duration-s 3`: LiDAR, a moving ego, tracks."""
    out = tmp_path_factory.mktemp("sim") / "rec"
    subprocess.run(
        [str(pmon_bin), "simulate", "--scenario", "pedestrians", "--seed", "7", "--duration-s", "3", "--out", str(out)],
        check=True,
        capture_output=True,
    )
    return out


def cli_records(pmon_bin, spec, *extra):
    """`pmon check SPEC --format jsonl` parsed: the per-object and missed-object records (totals dropped)."""
    import json

    p = subprocess.run(
        [str(pmon_bin), "check", str(spec), "--format", "jsonl", *extra], capture_output=True, text=True
    )
    assert p.returncode in (0, 1), p.stderr
    records = [json.loads(line) for line in p.stdout.splitlines() if line.strip()]
    return [r for r in records if r.get("record") != "totals"]


# `pmon reproduce` on the smoke plan (every figure and every curve of --quick, three points per sweep: 68 runs against
# --quick's 264) over 1 s scenes, to keep CI short; no real data (that part runs in the driving process whatever the
# scheduler). test_reproduce.py compares it with the scheduled runs, test_intervals.py recomputes its intervals.
REPRODUCE_ARGS = ["reproduce", "--smoke", "--duration-s", "1", "--seed", "5"]


def run_reproduce(pmon_bin, out, *extra):
    """`pmon reproduce` with REPRODUCE_ARGS into `out`, no real data; the finished process."""
    import sys

    # One absent data folder for every run: its path is in the report's notes.
    p = subprocess.run([str(pmon_bin), *REPRODUCE_ARGS, "--data", "/nonexistent/pmon-test-no-data", "--out", str(out),
                        "--python", sys.executable, *extra], capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, p.stderr
    return p


@pytest.fixture(scope="session")
def reproduce_local(pmon_bin, tmp_path_factory):
    """The single-process `pmon reproduce` (REPRODUCE_ARGS): its report folder, made once for the session."""
    local = tmp_path_factory.mktemp("reproduce-local") / "local"
    run_reproduce(pmon_bin, local, "--quiet")
    assert not Path(str(local) + ".run").exists()  # the local run needs no run folder
    return local


@pytest.fixture(scope="module")
def cluster():
    """A Dask LocalCluster of 2 single-thread worker processes, one per test module (skipped without Dask)."""
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None,
                                  processes=True) as c:
        yield c
