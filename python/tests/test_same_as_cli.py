"""The Python package against `pmon check --format jsonl`, record by record, on the same frames.

The CLI is the oracle: a separate process that reads the input with its own path (RecordedFrame -> Frame),
while the package goes through numpy arrays and the C API's session layer. Records are compared as the parsed
JSON values (`CheckResult.records()` renders floats in their shortest round-trip form, as serde_json does).
"""

import numpy as np
import pytest

import pmon
from conftest import cli_records


def python_records(frames, params):
    monitor = pmon.Monitor(params)
    out = []
    for f in frames:
        out.extend(monitor.check_frame(f).records())
    return out


def assert_same(py, cli):
    assert len(cli) > 0
    assert len(py) == len(cli)
    for i, (a, b) in enumerate(zip(py, cli)):
        assert a == b, f"record {i}: python {a} vs cli {b}"


def test_simulated_recording_gives_the_cli_verdicts(pmon_bin, sim_recording):
    rec = pmon.read_recording(sim_recording)
    py = python_records(rec, rec.params)
    cli = cli_records(pmon_bin, sim_recording)
    assert_same(py, cli)
    verdicts = {r["verdict"] for r in py}
    # A non-trivial run: the sensor checks confirmed objects and something was not monitored.
    assert "consistent" in verdicts and "not_monitored" in verdicts, verdicts


def test_kitti_gives_the_cli_verdicts(pmon_bin, data_dir):
    kitti = data_dir / "kitti" / "object" / "training"
    if not kitti.is_dir():
        pytest.skip(f"{kitti} not found: real-data comparison skipped")
    ds = pmon.datasets.kitti(kitti)
    assert len(ds) > 0
    py = python_records(ds, ds.params)
    cli = cli_records(pmon_bin, f"kitti:{kitti}")
    assert_same(py, cli)


def test_the_recall_profile_gives_the_cli_verdicts(pmon_bin, sim_recording, tmp_path):
    # Every object from the fifth frame on displaced 0.6 m along x (below dx_min, where the profile's rules find
    # more), written from Python; then `--params profile:recall` in the CLI against Params.profile here.
    def displaced(frames):
        for f in frames:
            if f.index >= 4:
                f.objects = dict(f.objects, x=f.objects["x"] + np.float32(0.6))
            yield f

    out = tmp_path / "displaced"
    pmon.write_recording(out, displaced(pmon.read_recording(sim_recording)), name="displaced")
    rec = pmon.read_recording(out)
    params = pmon.Params.profile("recall", base=rec.params)
    assert params != rec.params
    py = python_records(rec, params)
    assert_same(py, cli_records(pmon_bin, out, "--params", "profile:recall"))
    # The profile changes verdicts here, so the comparison above is not that of the defaults again.
    defaults = cli_records(pmon_bin, out)
    flagged = lambda records: sum(r.get("verdict") == "position_error" for r in records)
    assert flagged(py) > flagged(defaults), (flagged(py), flagged(defaults))


def test_a_recording_written_from_python_checks_the_same_in_the_cli(pmon_bin, sim_recording, tmp_path):
    out = tmp_path / "copy"
    n = pmon.write_recording(out, pmon.read_recording(sim_recording), name="copy")
    assert n == len(pmon.read_recording(sim_recording))
    rec = pmon.read_recording(sim_recording)
    assert_same(python_records(rec, rec.params), cli_records(pmon_bin, out))


def test_points_are_the_bytes_of_the_cloud_file(sim_recording):
    # An independent reader: numpy reads the little-endian float32 triples of the recording's cloud file.
    frame = next(iter(pmon.read_recording(sim_recording)))
    raw = np.fromfile(sim_recording / "clouds" / "000000.bin", dtype="<f4").reshape(-1, 3)
    assert frame.points.dtype == np.float32 and frame.points.flags.c_contiguous
    np.testing.assert_array_equal(frame.points, raw)


def test_table_i_defaults_are_the_cli_defaults(pmon_bin):
    import subprocess

    tomllib = pytest.importorskip("tomllib")
    text = subprocess.run([str(pmon_bin), "params"], capture_output=True, text=True, check=True).stdout
    assert_close(pmon.Params().to_dict(), tomllib.loads(text), "params")


def assert_close(py, cli, where):
    """Equal structure and values; floats equal at float32 precision (TOML and JSON print them differently)."""
    if isinstance(cli, dict):
        # TOML has no null: `pmon params` leaves out the keys whose value is None (no per-class override).
        py = {k: v for k, v in py.items() if v is not None}
        assert isinstance(py, dict) and set(py) == set(cli), where
        for k in cli:
            assert_close(py[k], cli[k], f"{where}.{k}")
    elif isinstance(cli, list):
        assert isinstance(py, list) and len(py) == len(cli), where
        for i, (a, b) in enumerate(zip(py, cli)):
            assert_close(a, b, f"{where}[{i}]")
    elif isinstance(cli, float):
        assert np.float32(py) == np.float32(cli) or py == cli, f"{where}: {py} vs {cli}"
    else:
        assert py == cli, f"{where}: {py!r} vs {cli!r}"
