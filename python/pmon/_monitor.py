"""``Monitor`` and ``CheckResult``: one call per frame into the Rust core."""

from __future__ import annotations

from typing import Any, Optional

import numpy as np

from . import _inputs, _pmon
from ._params import Params, ParamsLike, as_params

_CLASS_NAMES = np.asarray(_inputs.CLASS_NAMES, dtype=object)


def _json_value(v: Any) -> Any:
    """A value as ``pmon check --format jsonl`` writes it: floats in their shortest round-trip form at their own
    precision (float32 ``0.4`` is ``0.4``, as serde_json writes it), non-finite floats as ``None`` (JSON null)."""
    if isinstance(v, (list, tuple)):
        return [_json_value(x) for x in v]
    if isinstance(v, np.floating):
        return float(str(v)) if np.isfinite(v) else None
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, float):
        return v if np.isfinite(v) else None
    return v


class CheckResult:
    """What the monitor says about one frame.

    ``objects`` maps column names to numpy arrays with one entry per input object, in input order:

    - ``id`` (uint64), ``class`` (str), ``verdict`` (str: ``consistent``, ``ghost``, ``position_error``,
      ``implausible_motion``, ``not_monitored``, ``motion_only_consistent``), ``reason`` (why not monitored,
      else None), ``conditions`` (implausible motion's conditions), ``position_cause`` (which test found a
      position error: ``displaced_evidence``, ``evidence_followed``, ``jumped_from_evidence``, ``seen_through``,
      ``face_in_front``, ``returns_beyond``, ``evidence_released``,
      ``evidence_runs_on``, ``held_while_parked``; else None), ``sensor`` and ``motion`` (each check's
      own verdict text), ``kind`` / ``error_size`` / ``error_unit`` / ``severity`` (implausible motion: what
      is wrong and how much; None / NaN otherwise), ``is_alarm`` (bool);
    - the sensor checks: ``eta`` (consistency, eq. 5), ``margin_length_m``, ``margin_width_m``,
      ``visible_fraction``, ``offset_x_m`` / ``offset_y_m`` (estimated displacement: where the object's
      evidence lies relative to its box, ego frame), ``cluster`` (index into ``clusters`` or -1);
    - the motion checks: ``dt_s``, ``accel_mps2``, ``accel_margin_mps2``, ``turn_rate_radps``,
      ``turn_rate_margin_radps``, ``predicted_world_x_m`` / ``_y_m``, ``predicted_margin_x_m`` / ``_y_m``,
      ``position_residual_m``, ``position_allowance_m``.

    ``clusters`` are the conflict clusters (evidence no object explains): ``cells``, ``is_missed_object``,
    ``object`` (the object it is attributed to, -1 for none), ``in_roi``, ``roi`` (str: ``no_roi`` in a frame
    without a region of interest, ``inside``, ``no_return_in_roi``, ``grazing``: why it is in the region of
    interest or outside it), ``is_outside_roi`` (outside it and attributed to no object: excused, not an alarm),
    ``centroid_x_m`` / ``_y_m`` and the bounds ``min_x_m``, ``min_y_m``, ``max_x_m``, ``max_y_m``.
    :attr:`missed` keeps the missed-object alarms, :attr:`outside_roi` the clusters the region of interest
    excused.

    The field names follow ``pmon check --format jsonl`` (:meth:`records` gives exactly its records).
    """

    __slots__ = ("objects", "clusters", "sensor_status", "points_total", "points_in_band", "object_alarms",
                 "missed_objects", "timestamp_s", "frame", "core_time_s")

    def __init__(self, objects: dict, clusters: dict, summary: dict, timestamp_s: float, frame: Optional[int]):
        self.objects = objects
        self.clusters = clusters
        self.sensor_status: Optional[str] = summary["sensor_status"]
        self.points_total: int = summary["points_total"]
        self.points_in_band: int = summary["points_in_band"]
        self.object_alarms: int = summary["object_alarms"]
        self.missed_objects: int = summary["missed_objects"]
        self.core_time_s: Optional[float] = summary.get("core_time_s")
        self.timestamp_s = timestamp_s
        self.frame = frame

    def __len__(self) -> int:
        return len(self.objects["id"])

    def __repr__(self) -> str:
        counts = dict(zip(*np.unique(self.objects["verdict"].astype(str), return_counts=True))) if len(self) else {}
        status = f", sensor checks not run: {self.sensor_status}" if self.sensor_status else ""
        return (f"CheckResult({len(self)} objects {counts}, {self.missed_objects} missed objects, "
                f"{self.points_total} points{status})")

    @property
    def missed(self) -> dict:
        """The missed-object alarms: clusters in the region of interest that no object explains."""
        keep = self.clusters["is_missed_object"]
        return {k: v[keep] for k, v in self.clusters.items()}

    @property
    def outside_roi(self) -> dict:
        """The clusters the region of interest excused (not alarms): outside it, attributed to no object; ``roi``
        says why (``no_return_in_roi`` or ``grazing``)."""
        keep = self.clusters["is_outside_roi"]
        return {k: v[keep] for k, v in self.clusters.items()}

    def to_pandas(self):
        """The per-object columns as a ``pandas.DataFrame`` (needs pandas)."""
        import pandas as pd

        return pd.DataFrame(self.objects)

    def clusters_to_pandas(self):
        """The conflict clusters as a ``pandas.DataFrame`` (needs pandas)."""
        import pandas as pd

        return pd.DataFrame(self.clusters)

    def records(self) -> list:
        """The records ``pmon check --format jsonl`` writes for this frame (objects, then missed objects, then the
        clusters outside the region of interest with their reason), as the dicts ``json.loads`` gives for its
        lines: same keys, same values (floats in their shortest round-trip form at the monitor's precision,
        non-finite ones as ``None``)."""
        o = self.objects
        out = []
        frame = self.frame if self.frame is not None else 0
        for i in range(len(self)):
            r = {
                "frame": frame,
                "timestamp_s": self.timestamp_s,
                "id": int(o["id"][i]),
                "class": o["class"][i],
                "verdict": o["verdict"][i],
            }
            if o["reason"][i] is not None:
                r["reason"] = o["reason"][i]
            if o["conditions"][i] is not None:
                r["conditions"] = o["conditions"][i]
            if o["position_cause"][i] is not None:
                r["position_cause"] = o["position_cause"][i]
            r["sensor"] = o["sensor"][i]
            r["motion"] = o["motion"][i]
            for k in ("eta", "margin_length_m", "margin_width_m", "visible_fraction"):
                r[k] = o[k][i]
            r["offset_m"] = [o["offset_x_m"][i], o["offset_y_m"][i]]
            for k in ("dt_s", "accel_mps2", "accel_margin_mps2", "turn_rate_radps", "turn_rate_margin_radps"):
                r[k] = o[k][i]
            r["predicted_world_m"] = [o["predicted_world_x_m"][i], o["predicted_world_y_m"][i]]
            r["predicted_margin_m"] = [o["predicted_margin_x_m"][i], o["predicted_margin_y_m"][i]]
            r["position_residual_m"] = o["position_residual_m"][i]
            r["position_allowance_m"] = o["position_allowance_m"][i]
            if o["kind"][i] is not None:
                r["kind"] = o["kind"][i]
                r["error_size"] = o["error_size"][i]
                r["error_unit"] = o["error_unit"][i]
                r["severity"] = o["severity"][i]
            out.append({k: _json_value(v) for k, v in r.items()})
        # The missed objects, then the clusters the region of interest excused (with their reason).
        for verdict, c in (("missed_object", self.missed), ("outside_roi", self.outside_roi)):
            for i in range(len(c["cells"])):
                r = {"frame": frame, "timestamp_s": self.timestamp_s, "verdict": verdict}
                if verdict == "outside_roi":
                    r["reason"] = c["roi"][i]
                r["centroid_m"] = [c["centroid_x_m"][i], c["centroid_y_m"][i]]
                r["bounds_m"] = [c["min_x_m"][i], c["min_y_m"][i], c["max_x_m"][i], c["max_y_m"][i]]
                r["cells"] = int(c["cells"][i])
                out.append({k: _json_value(v) for k, v in r.items()})
        return out


class Monitor:
    """The pmon monitor: sensor checks (LiDAR evidence in an occupancy grid) and plausibility checks (motion)
    on one object list per frame.

    ``params``: ``None`` (the paper's Table I), a :class:`pmon.Params`, a dict of overrides (any subset of the
    keys of ``pmon params``) or the path of a TOML parameter file. Bad parameters raise ``ValueError`` with the
    message of the Rust side.

    A monitor keeps per-track history for the plausibility checks: use one monitor per sequence, and feed it
    frames in time order. It is not thread-safe; the GIL is released while the core runs, so several monitors
    can work in parallel threads.
    """

    def __init__(self, params: ParamsLike = None) -> None:
        self.params: Params = as_params(params)
        self._core = _pmon.Monitor(self.params.to_json())

    def __repr__(self) -> str:
        return f"Monitor({self.params!r})"

    def check(
        self,
        points: Optional[np.ndarray],
        objects: Any,
        *,
        timestamp_s: float,
        world_from_ego: Any = None,
        roi: Any = None,
        static: Any = None,
        ego_from_sensor: Any = None,
        frame: Optional[int] = None,
        _core_time: bool = False,
    ) -> CheckResult:
        """Checks one frame.

        - ``points``: the LiDAR sweep, an ``(N, 3)`` or ``(N, 4)`` float32 array in the sensor frame (x, y, z
          [, intensity ignored], metres), or ``None`` when the frame has none (only the plausibility checks
          run). A C-contiguous array is read in place, without a copy; other float dtypes are refused.
        - ``objects``: the object list in the ego frame: a dict of equal-length arrays, a structured numpy
          array or a pandas DataFrame with the columns ``id`` (non-negative integers), ``class`` (names as
          ``pmon.CLASS_NAMES`` or their codes), ``x``, ``y`` (m), ``heading`` (rad), ``speed`` (m/s, over
          ground), ``length``, ``width`` (m), and optionally ``uncertainty``: ``(N, 6)`` one-sigma values (the
          covariance's diagonal as standard deviations: x, y, heading, speed, length, width); a row of NaN uses
          the parameters' ``default_uncertainty``. ``None`` or empty columns: no objects.
        - ``timestamp_s``: seconds, strictly increasing from frame to frame.
        - ``world_from_ego``: the ego pose ``(x_m, y_m, yaw_rad)`` in a fixed frame; ``None`` = identity.
        - ``roi``, ``static``: lists of ``(K, 2)`` polygons in the ego frame (region of interest, known static
          scenery); ``None`` = none.
        - ``ego_from_sensor``: the LiDAR extrinsic as a ``(4, 4)`` or ``(3, 4)`` matrix; ``None`` = identity.
        - ``frame``: a frame number carried into :meth:`CheckResult.records`.

        Bad arguments (wrong dtypes or shapes, unknown columns or classes, negative ids, more objects than
        ``max_objects``) raise ``ValueError`` and leave the monitor's state as it was; bad *values* in an
        object (NaN, negative size) and duplicate ids are judged by the monitor: ``not_monitored`` with the
        reason (``invalid_state``, ``duplicate_id``), as are an empty cloud (``empty_cloud``) or a
        non-increasing timestamp (``time_step_not_positive``).
        """
        pts = _inputs.points_array(points)
        cols = _inputs.object_columns(objects)
        t = _inputs.timestamp(timestamp_s)
        o, c, s = self._core.check(
            t,
            _inputs.pose(world_from_ego),
            pts,
            _inputs.extrinsic(ego_from_sensor),
            cols,
            _inputs.polygon_list(roi, "roi"),
            _inputs.polygon_list(static, "static"),
            _core_time,
        )
        o["class"] = _CLASS_NAMES[cols["classes"]]
        return CheckResult(o, c, s, t, frame)

    def check_frame(self, frame: Any) -> CheckResult:
        """Checks a :class:`pmon.Frame` (from a reader or :func:`pmon.read_recording`)."""
        return self.check(
            frame.points,
            frame.objects,
            timestamp_s=frame.timestamp_s,
            world_from_ego=frame.world_from_ego,
            roi=frame.roi,
            static=frame.static,
            ego_from_sensor=frame.ego_from_sensor,
            frame=frame.index,
        )
