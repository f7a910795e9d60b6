"""The dataset readers of ``pmon check`` (``docs/datasets.md``) as iterators of :class:`pmon.Frame`.

Each function takes the same path as the ``pmon`` command's ``scheme:path`` spec and the same region-of-
interest options (``roi``: ``"auto"``, ``"none"`` or ``"corridor:<width_m>"``; ``sidewalk_m``), and returns a
:class:`pmon.Dataset` whose ``params`` are what ``pmon check`` uses for it::

    ds = pmon.datasets.kitti("data/kitti/object/training")
    monitor = pmon.Monitor(ds.params)
    for frame in ds:
        result = monitor.check_frame(frame)

A missing folder or a malformed file raises ``ValueError`` naming the file (and line where there is one).
"""

from __future__ import annotations

import os
from typing import Optional, Union

from . import _pmon
from ._frames import Dataset

PathLike = Union[str, "os.PathLike[str]"]

#: The ``scheme:`` prefixes the readers know.
SCHEMES = tuple(_pmon.dataset_schemes())


def open(spec: str, *, roi: str = "auto", sidewalk_m: float = 0.0, grid_size_m: Optional[float] = None) -> Dataset:
    """A dataset from a ``scheme:path`` spec, as ``pmon check`` takes it (``kitti:DIR``, ``av2:LOG_DIR``, ...)."""
    return Dataset(spec, roi=roi, sidewalk_m=sidewalk_m, grid_size_m=grid_size_m)


def kitti(path: PathLike, **options) -> Dataset:
    """KITTI object detection (``training/`` with ``velodyne/``, ``label_2/``, ``calib/``)."""
    return open(f"kitti:{os.fspath(path)}", **options)


def kitti_tracking(path: PathLike, **options) -> Dataset:
    """A KITTI tracking label file (object lists only)."""
    return open(f"kitti-tracking:{os.fspath(path)}", **options)


def nuscenes(path: PathLike, **options) -> Dataset:
    """nuScenes in pmon's extract layout (docs/datasets.md)."""
    return open(f"nuscenes:{os.fspath(path)}", **options)


def nuscenes_v1(path: PathLike, scene: Optional[str] = None, **options) -> Dataset:
    """nuScenes v1.0 tables (``v1.0-mini`` and the like), optionally one scene by name."""
    spec = f"nuscenes-v1:{os.fspath(path)}" + (f"#{scene}" if scene else "")
    return open(spec, **options)


def av2(path: PathLike, **options) -> Dataset:
    """One Argoverse 2 sensor log (its vector map gives the region of interest with ``roi="auto"``)."""
    return open(f"av2:{os.fspath(path)}", **options)


def commonroad(path: PathLike, **options) -> Dataset:
    """A CommonRoad scenario (``.xml``): object lists only."""
    return open(f"commonroad:{os.fspath(path)}", **options)
