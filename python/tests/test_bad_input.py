"""Bad input gives a ValueError naming what is wrong, or a not-monitored verdict with the reason; never a crash,
and a refused call leaves the monitor's state as it was."""

import numpy as np
import pytest

import pmon


def car(**over):
    o = {"id": [1], "class": ["car"], "x": [10.0], "y": [0.0], "heading": [0.0], "speed": [5.0],
         "length": [4.5], "width": [1.8]}
    o.update(over)
    return o


def wall():
    """The rear face of the car above (x = 10 m, 4.5 m long) as the LiDAR at 1.8 m height sees it: evidence
    that confirms it (sensor frame)."""
    pts = [(7.9, y, z) for y in np.arange(-0.8, 0.81, 0.05) for z in (-1.2, -1.0, -0.8)]
    return np.asarray(pts, dtype=np.float32)


EXTRINSIC = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1.8], [0, 0, 0, 1]], dtype=np.float32)


def check(m, points, objects, t=0.0, **kw):
    return m.check(points, objects, timestamp_s=t, ego_from_sensor=EXTRINSIC, **kw)


def test_a_box_with_evidence_is_consistent():
    r = check(pmon.Monitor(), wall(), car())
    assert r.objects["verdict"][0] == "consistent", r.records()
    assert r.objects["eta"][0] > 0.5


@pytest.mark.parametrize(
    "points, what",
    [
        (np.zeros((5, 3), dtype=np.float64), "float32"),
        (np.zeros((5, 3), dtype=np.int32), "float32"),
        (np.zeros((5, 2), dtype=np.float32), "shape"),
        (np.zeros((5, 5), dtype=np.float32), "shape"),
        (np.zeros(15, dtype=np.float32), "shape"),
        (np.zeros((2, 5, 3), dtype=np.float32), "shape"),
        ([[0.0, 0.0, 0.0]], "numpy array"),
    ],
)
def test_bad_points_are_refused(points, what):
    with pytest.raises(ValueError, match=what):
        pmon.Monitor().check(points, car(), timestamp_s=0.0)


def test_strided_and_four_column_clouds_give_the_same_answer():
    pts = wall()
    base = check(pmon.Monitor(), pts, car()).records()
    four = np.hstack([pts, np.ones((len(pts), 1), np.float32)])
    assert check(pmon.Monitor(), four, car()).records() == base
    strided = np.asfortranarray(pts)
    assert not strided.flags.c_contiguous
    assert check(pmon.Monitor(), strided, car()).records() == base
    assert check(pmon.Monitor(), four[:, :3], car()).records() == base


def test_empty_cloud_and_no_cloud_are_not_monitored_with_the_reason():
    r = check(pmon.Monitor(), np.zeros((0, 3), np.float32), car())
    assert (r.objects["verdict"][0], r.objects["reason"][0]) == ("not_monitored", "empty_cloud")
    assert r.sensor_status == "empty_cloud"
    r = check(pmon.Monitor(), None, car())
    assert r.sensor_status == "no_lidar_data"
    assert r.objects["verdict"][0] == "not_monitored"


def test_nan_points_do_not_crash():
    pts = wall()
    pts[::3] = np.nan
    r = check(pmon.Monitor(), pts, car())
    assert len(r) == 1 and r.objects["verdict"][0] in {"consistent", "not_monitored", "ghost", "position_error"}


def test_nan_in_an_object_is_invalid_state_and_the_others_are_judged():
    objs = {"id": [1, 2], "class": ["car", "car"], "x": [10.0, np.nan], "y": [0.0, 5.0], "heading": [0.0, 0.0],
            "speed": [5.0, 5.0], "length": [4.5, 4.5], "width": [1.8, -1.0]}
    r = check(pmon.Monitor(), wall(), objs)
    assert r.objects["verdict"][0] == "consistent"
    assert (r.objects["verdict"][1], r.objects["reason"][1]) == ("not_monitored", "invalid_state")


def test_duplicate_ids_are_not_monitored():
    objs = car(id=[7, 7], **{k: v * 2 for k, v in car().items() if k != "id"})
    r = check(pmon.Monitor(), wall(), objs)
    # The plausibility checks cannot tell the two tracks apart; the sensor checks still judge each box.
    assert list(r.objects["motion"]) == ["not_monitored(duplicate_id)"] * 2, r.records()
    assert r.objects["verdict"][0] == "consistent"


def test_time_that_does_not_advance_and_nan_time_are_not_monitored():
    m = pmon.Monitor()
    check(m, None, car(), t=1.0)
    r = check(m, None, car(), t=1.0)
    assert "time_step_not_positive" in r.objects["motion"][0]
    r = check(m, None, car(), t=float("nan"))
    assert "invalid_timestamp" in r.objects["motion"][0] or r.objects["reason"][0] == "invalid_timestamp"


def test_empty_object_lists():
    m = pmon.Monitor()
    empty = {k: np.zeros(0) if k not in ("id", "class") else np.zeros(0, dtype=np.uint64) for k in car()}
    r = check(m, wall(), empty)
    assert len(r) == 0 and r.to_pandas().shape[0] == 0
    assert len(check(m, wall(), None, t=1.0)) == 0


@pytest.mark.parametrize(
    "objects, what",
    [
        (car(colour=["red"]), "unknown column"),
        ({k: v for k, v in car().items() if k != "speed"}, "missing column"),
        (car(**{"class": ["spaceship"]}), "unknown class"),
        (car(**{"class": [9]}), "class code 9"),
        (car(id=[-1]), "negative"),
        (car(id=[1.5]), "integers"),
        (car(x=[1.0, 2.0]), "entries"),
        (car(x=["ten"]), "real numbers"),
        (car(uncertainty=np.zeros((1, 5))), r"shape \(1, 6\)"),
        (np.zeros(3), "structured"),
        ("objects", "dict"),
    ],
)
def test_bad_object_lists_are_refused(objects, what):
    with pytest.raises(ValueError, match=what):
        check(pmon.Monitor(), wall(), objects)


def test_a_refused_frame_leaves_the_tracks_alone():
    m, ref = pmon.Monitor(), pmon.Monitor()
    check(m, None, car(), t=0.0)
    check(ref, None, car(), t=0.0)
    with pytest.raises(ValueError):
        check(m, None, car(x=["bad"]), t=0.1)
    assert check(m, None, car(x=[10.5]), t=0.1).records() == check(ref, None, car(x=[10.5]), t=0.1).records()


def test_more_objects_than_max_objects_is_an_error():
    m = pmon.Monitor({"max_objects": 2})
    n = 3
    objs = {"id": np.arange(n), "class": ["car"] * n, "x": np.arange(n) * 10.0, "y": np.zeros(n),
            "heading": np.zeros(n), "speed": np.zeros(n), "length": np.full(n, 4.5), "width": np.full(n, 1.8)}
    with pytest.raises(ValueError, match="objects"):
        check(m, wall(), objs)


def test_structured_arrays_and_dataframes_are_object_lists():
    dtype = [("id", "u8"), ("class", "U12"), ("x", "f4"), ("y", "f4"), ("heading", "f4"), ("speed", "f4"),
             ("length", "f4"), ("width", "f4"), ("uncertainty", "f4", (6,))]
    arr = np.zeros(2, dtype=dtype)
    arr["id"] = [1, 2]
    arr["class"] = ["car", "pedestrian"]
    arr["x"] = [10.0, 20.0]
    arr["length"], arr["width"] = [4.5, 0.6], [1.8, 0.6]
    arr["uncertainty"][0] = np.nan
    arr["uncertainty"][1] = [0.2, 0.2, 0.1, 0.5, 0.1, 0.1]
    as_dict = {k: arr[k] for k in arr.dtype.names}
    a = check(pmon.Monitor(), wall(), arr).records()
    assert a == check(pmon.Monitor(), wall(), as_dict).records()
    pd = pytest.importorskip("pandas")
    df = pd.DataFrame({k: arr[k] for k in arr.dtype.names if k != "uncertainty"})
    df["uncertainty"] = list(arr["uncertainty"])
    assert check(pmon.Monitor(), wall(), df).records() == a
    out = check(pmon.Monitor(), wall(), df).to_pandas()
    assert list(out["id"]) == [1, 2] and "verdict" in out.columns and "eta" in out.columns


def test_bad_world_pose_and_extrinsic_and_polygons_are_refused():
    m = pmon.Monitor()
    with pytest.raises(ValueError, match="world_from_ego"):
        m.check(None, car(), timestamp_s=0.0, world_from_ego=(1.0, 2.0))
    with pytest.raises(ValueError, match="ego_from_sensor"):
        m.check(wall(), car(), timestamp_s=0.0, ego_from_sensor=np.eye(3))
    with pytest.raises(ValueError, match="roi"):
        m.check(wall(), car(), timestamp_s=0.0, roi=[np.zeros((4, 3))])
    with pytest.raises(ValueError, match="timestamp_s"):
        m.check(wall(), car(), timestamp_s="now")


def test_parameters_unknown_keys_bad_values_bad_files(tmp_path):
    with pytest.raises(ValueError, match="unknown field `cell_sise_m`"):
        pmon.Params(cell_sise_m=0.2)
    with pytest.raises(ValueError, match="cell_size_m"):
        pmon.Monitor({"cell_size_m": -1.0})
    with pytest.raises(ValueError, match="accel"):
        pmon.Params(motion_limits={"accel": 5.0})
    with pytest.raises(ValueError):
        pmon.Params(cell_size_m=float("nan"))
    with pytest.raises(ValueError, match="nope.toml"):
        pmon.Monitor(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("tau_tpp = 0.9\n")
    with pytest.raises(ValueError, match="bad.toml.*tau_tpp"):
        pmon.Params.from_toml(bad)
    with pytest.raises(ValueError, match="params must be"):
        pmon.Monitor(42)


def test_parameters_layer_like_the_cli(tmp_path):
    p = pmon.Params(motion_limits={"accel_max_mps2": 5.0})
    d = pmon.Params()
    assert p.motion_limits["accel_max_mps2"] == 5.0
    assert p.motion_limits["brake_max_mps2"] == d.motion_limits["brake_max_mps2"]
    f = tmp_path / "p.toml"
    f.write_text(p.replace(tau_fn=0.9).to_toml())
    assert pmon.Params.from_toml(f) == p.replace(tau_fn=0.9)
    with pytest.raises(AttributeError):
        p.tau_fn = 0.1
    import pickle

    assert pickle.loads(pickle.dumps(p)) == p


def test_profiles_load_by_name_like_the_cli(tmp_path, monkeypatch):
    d = pmon.Params()
    r = pmon.Params.profile("recall")
    assert pmon.Params.profiles() == ["recall"]
    assert r == d.replace(returns_beyond_cells=1, face_in_front=True, seen_over=True)
    assert "returns_beyond_cells = 1" in pmon.Params.profile_text("recall")
    # The same profile wherever a parameter file is accepted, and over a base as `--params` layers it.
    assert pmon.Params.from_toml("profile:recall") == r
    assert pmon._params.as_params("profile:recall") == r
    base = d.replace(cell_size_m=0.2)
    assert pmon.Params.profile("recall", base=base) == r.replace(cell_size_m=0.2)
    assert pmon.Monitor("profile:recall").params == r
    with pytest.raises(ValueError, match="unknown parameter profile `fast`.*profile:recall"):
        pmon.Params.profile("fast")
    with pytest.raises(ValueError, match="unknown parameter profile `fast`"):
        pmon.Monitor("profile:fast")
    # A file whose name begins with `profile:` is given as `./profile:...`.
    monkeypatch.chdir(tmp_path)
    (tmp_path / "profile:mine").write_text("tau_fn = 0.9\n")
    assert pmon.Params.from_toml("./profile:mine") == d.replace(tau_fn=0.9)


def test_recordings_bad_paths_and_no_overwrite(tmp_path):
    with pytest.raises(ValueError, match="missing"):
        pmon.read_recording(tmp_path / "missing")
    target = tmp_path / "full"
    target.mkdir()
    (target / "mine.txt").write_text("keep me")
    f = pmon.Frame(index=0, timestamp_s=0.0, objects=car())
    with pytest.raises(ValueError, match="not empty"):
        pmon.write_recording(target, [f])
    assert (target / "mine.txt").read_text() == "keep me"
    with pytest.raises(ValueError, match="increase strictly"):
        pmon.write_recording(tmp_path / "t", [f, pmon.Frame(index=1, timestamp_s=0.0, objects=car())])


def test_a_truncated_recording_names_file_and_line(tmp_path):
    out = tmp_path / "rec"
    frames = [pmon.Frame(index=i, timestamp_s=0.1 * i, objects=car(x=[10.0 + 0.5 * i]), points=wall(),
                         ego_from_sensor=EXTRINSIC) for i in range(3)]
    assert pmon.write_recording(out, frames) == 3
    lines = (out / "frames.jsonl").read_text().splitlines()
    (out / "frames.jsonl").write_text("\n".join(lines[:2]) + "\n" + lines[2][: len(lines[2]) // 2] + "\n")
    it = iter(pmon.read_recording(out))
    next(it), next(it)
    with pytest.raises(ValueError, match=r"frames.jsonl.*3"):
        next(it)


def test_datasets_missing_folder_is_an_error(tmp_path):
    with pytest.raises(ValueError):
        pmon.datasets.kitti(tmp_path / "nowhere")
    with pytest.raises(ValueError, match="roi"):
        pmon.datasets.kitti(tmp_path, roi="sometimes")
