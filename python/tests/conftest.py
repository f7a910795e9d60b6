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


@pytest.fixture(scope="module")
def cluster():
    """A Dask LocalCluster of 2 single-thread worker processes, one per test module (skipped without Dask)."""
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None,
                                  processes=True) as c:
        yield c
