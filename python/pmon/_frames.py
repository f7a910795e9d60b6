"""Frames, the recording format and the dataset readers as iterators of frames."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Iterable, Iterator, List, Optional, Tuple, Union

import numpy as np

from . import _inputs, _pmon
from ._params import Params

PathLike = Union[str, "os.PathLike[str]"]


@dataclass
class Frame:
    """One frame: what the monitor is given.

    - ``index``: frame number within its sequence (from 0).
    - ``timestamp_s``: seconds.
    - ``objects``: the object list, ego frame: a dict of equal-length numpy arrays ``id`` (uint64), ``class``
      (names), ``x``, ``y``, ``heading``, ``speed``, ``length``, ``width`` (float32) and ``uncertainty``
      (float32 ``(N, 6)``, a row of NaN where the object has none). Any value ``Monitor.check`` takes as
      ``objects`` may be put here instead.
    - ``points``: the LiDAR sweep in the sensor frame, ``(N, 3)`` float32, or ``None``.
    - ``ego_from_sensor``: the extrinsic as a ``(4, 4)`` float32 matrix, or ``None`` (identity).
    - ``world_from_ego``: the ego pose ``(x_m, y_m, yaw_rad)``.
    - ``roi``, ``static``: polygons ``(K, 2)`` in the ego frame: region of interest and known static scenery.
    """

    index: int
    timestamp_s: float
    objects: Any
    points: Optional[np.ndarray] = None
    ego_from_sensor: Optional[np.ndarray] = None
    world_from_ego: Tuple[float, float, float] = (0.0, 0.0, 0.0)
    roi: List[np.ndarray] = field(default_factory=list)
    static: List[np.ndarray] = field(default_factory=list)

    @classmethod
    def _from_core(cls, d: dict) -> "Frame":
        o = d["objects"]
        state = o["state"]
        names = np.asarray(_inputs.CLASS_NAMES, dtype=object)
        objects = {
            "id": o["ids"],
            "class": names[o["classes"]],
            "x": state[:, 0],
            "y": state[:, 1],
            "heading": state[:, 2],
            "speed": state[:, 3],
            "length": state[:, 4],
            "width": state[:, 5],
            "uncertainty": o["uncertainty"],
        }
        e = d["ego_from_sensor"]
        if e is not None:
            e = np.vstack([e, np.array([[0, 0, 0, 1]], dtype=np.float32)])
        return cls(
            index=d["index"],
            timestamp_s=d["timestamp_s"],
            objects=objects,
            points=d["points"],
            ego_from_sensor=e,
            world_from_ego=tuple(d["world_from_ego"]),
            roi=list(d["roi"]),
            static=list(d["static"]),
        )

    def objects_to_pandas(self):
        """The object list as a ``pandas.DataFrame`` (the uncertainty as six ``sigma_*`` columns)."""
        import pandas as pd

        o = dict(self.objects)
        u = o.pop("uncertainty", None)
        df = pd.DataFrame(o)
        if u is not None:
            for j, k in enumerate(("x", "y", "heading", "speed", "length", "width")):
                df[f"sigma_{k}"] = np.asarray(u)[:, j]
        return df


class Recording:
    """A pmon recording (``docs/recording-format.md``) read frame by frame: iterate over it for
    :class:`Frame` objects. ``params`` are the parameters ``pmon check`` would use for it (Table I, or the
    recording's ``params.toml`` over them). A malformed line raises ``ValueError`` naming file and line when
    the iteration reaches it. Iterate it once; open it again to start over."""

    def __init__(self, path: PathLike) -> None:
        self.path = os.fspath(path)
        self._core = _pmon.RecordingFrames(self.path)
        self.name: str = self._core.name
        self.source: str = self._core.source
        self.params: Params = Params._from_json(self._core.params_json)
        self.params_file: Optional[str] = None if self._core.params_file is None else str(self._core.params_file)

    def __iter__(self) -> Iterator[Frame]:
        for d in self._core:
            yield Frame._from_core(d)

    def __len__(self) -> int:
        if self._core.frames is None:
            raise TypeError("a bare .jsonl object list does not announce its number of frames")
        return int(self._core.frames)

    def __repr__(self) -> str:
        return f"Recording({self.path!r}, name={self.name!r})"


def read_recording(path: PathLike) -> Recording:
    """Opens a pmon recording (a directory with ``recording.json``, or a ``.jsonl`` object list)."""
    return Recording(path)


def write_recording(path: PathLike, frames: Iterable[Any], *, name: str = "", source: str = "pmon (Python)") -> int:
    """Writes ``frames`` (any objects with the attributes of :class:`Frame`) as a pmon recording in the new or
    empty directory ``path``; returns the number of frames. Frames are numbered 0, 1, ... in the order given;
    timestamps must be finite and strictly increasing. Existing data is never overwritten: a non-empty
    directory is refused. The points are stored as ``(N, 3)`` float32 (a fourth column is dropped)."""
    writer = _pmon.RecordingWriter(os.fspath(path), name, source)
    for f in frames:
        pts = _inputs.points_array(getattr(f, "points", None))
        if pts is not None and pts.shape[1] == 4:
            pts = np.ascontiguousarray(pts[:, :3])
        writer.write(
            _inputs.timestamp(f.timestamp_s),
            _inputs.pose(getattr(f, "world_from_ego", None)),
            pts,
            _inputs.extrinsic(getattr(f, "ego_from_sensor", None)),
            _inputs.object_columns(f.objects),
            _inputs.polygon_list(getattr(f, "roi", None), "roi"),
            _inputs.polygon_list(getattr(f, "static", None), "static"),
        )
    return writer.finish()


class Dataset:
    """A dataset in its native layout, read by pmon's readers (``docs/datasets.md``): iterate over it for
    :class:`Frame` objects. ``params`` are the defaults with the dataset's ground height and ego footprint,
    as ``pmon check`` uses them; ``notes`` say what the reader assumed (a nominal calibration, where the
    region of interest comes from). The reader loads the annotations and sweeps when it opens the dataset;
    iterate it once (``len`` counts the frames not yet taken); open it again to start over."""

    def __init__(self, spec: str, *, roi: str = "auto", sidewalk_m: float = 0.0, grid_size_m: Optional[float] = None):
        self.spec = spec
        self._core = _pmon.DatasetFrames(spec, roi, float(sidewalk_m), grid_size_m)
        self.name: str = self._core.name
        self.params: Params = Params._from_json(self._core.params_json)
        self.notes: List[str] = list(self._core.notes)

    def __iter__(self) -> Iterator[Frame]:
        for d in self._core:
            yield Frame._from_core(d)

    def __len__(self) -> int:
        return len(self._core)

    def __repr__(self) -> str:
        return f"Dataset({self.spec!r}, {len(self)} frames left)"
