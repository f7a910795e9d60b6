"""Checks and converts what a caller hands to ``Monitor.check`` and ``write_recording``.

Everything here raises ``ValueError`` with a message that names the argument; the Rust side checks again.
"""

from __future__ import annotations

from typing import Any, Mapping, Optional, Sequence

import numpy as np

from . import _pmon

CLASS_NAMES: tuple = tuple(_pmon.class_names())
_CLASS_CODES = {name: i for i, name in enumerate(CLASS_NAMES)}
_STATE_COLUMNS = ("x", "y", "heading", "speed", "length", "width")
OBJECT_COLUMNS = ("id", "class") + _STATE_COLUMNS + ("uncertainty",)
_REQUIRED = ("id", "class") + _STATE_COLUMNS


def points_array(points: Any) -> Optional[np.ndarray]:
    """``None`` or a C-contiguous float32 ``(N, 3|4)`` array (the caller's own array when it already is one)."""
    if points is None:
        return None
    if not isinstance(points, np.ndarray):
        raise ValueError(f"points must be a numpy array of shape (N, 3) or (N, 4), got {type(points).__name__}")
    if points.dtype != np.float32:
        raise ValueError(
            f"points must be float32 (got {points.dtype}); convert once with points.astype(np.float32)"
        )
    if points.ndim != 2 or points.shape[1] not in (3, 4):
        raise ValueError(f"points must have shape (N, 3) or (N, 4), got {points.shape}")
    # A strided view (a column slice, a transposed array) is copied once; a contiguous array is read in place.
    return np.ascontiguousarray(points)


def _column(objects: Any, name: str) -> Any:
    try:
        return objects[name]
    except (KeyError, ValueError, IndexError):
        return None


def _names(objects: Any) -> Sequence[str]:
    if isinstance(objects, np.ndarray):
        if objects.dtype.names is None:
            raise ValueError(
                "objects must be a dict of equal-length arrays, a structured numpy array or a pandas DataFrame "
                f"(got a plain array of dtype {objects.dtype})"
            )
        return list(objects.dtype.names)
    if hasattr(objects, "columns"):  # pandas DataFrame
        return [str(c) for c in objects.columns]
    if isinstance(objects, Mapping):
        return [str(k) for k in objects.keys()]
    raise ValueError(
        "objects must be a dict of equal-length arrays, a structured numpy array or a pandas DataFrame, "
        f"got {type(objects).__name__}"
    )


def _real(values: Any, name: str, n: Optional[int]) -> np.ndarray:
    a = np.asarray(values)
    if a.dtype.kind not in "fiu":
        raise ValueError(f"objects[{name!r}] must be real numbers, got dtype {a.dtype}")
    if a.ndim != 1:
        raise ValueError(f"objects[{name!r}] must be one-dimensional, got shape {a.shape}")
    if n is not None and len(a) != n:
        raise ValueError(f"objects[{name!r}] has {len(a)} entries, objects['id'] has {n}")
    return a


def object_columns(objects: Any) -> dict:
    """The object list as the Rust side takes it: ``ids`` uint64, ``classes`` uint8 codes, ``state`` float32
    ``(N, 6)`` (x, y, heading, speed, length, width) and optionally ``uncertainty`` float32 ``(N, 6)`` with a
    flag per row (a row of NaN means "not given": the parameters' ``default_uncertainty`` applies)."""
    if objects is None:
        empty = np.zeros(0, dtype=np.float32)
        return {
            "ids": np.zeros(0, dtype=np.uint64),
            "classes": np.zeros(0, dtype=np.uint8),
            "state": empty.reshape(0, 6),
            "uncertainty": None,
            "has_uncertainty": None,
        }
    names = _names(objects)
    unknown = [k for k in names if k not in OBJECT_COLUMNS]
    if unknown:
        raise ValueError(f"objects: unknown column(s) {unknown} (known: {', '.join(OBJECT_COLUMNS)})")
    missing = [k for k in _REQUIRED if k not in names]
    if missing:
        raise ValueError(f"objects: missing column(s) {missing} (required: {', '.join(_REQUIRED)})")
    ids = np.asarray(_column(objects, "id"))
    if ids.ndim != 1:
        raise ValueError(f"objects['id'] must be one-dimensional, got shape {ids.shape}")
    if ids.dtype.kind == "u":
        ids = np.ascontiguousarray(ids, dtype=np.uint64)
    elif ids.dtype.kind == "i":
        if len(ids) and ids.min() < 0:
            raise ValueError(f"objects['id'] must not be negative (row {int(np.argmin(ids))}: {ids.min()})")
        ids = ids.astype(np.uint64)
    else:
        raise ValueError(f"objects['id'] must be integers, got dtype {ids.dtype}")
    n = len(ids)
    classes = np.asarray(_column(objects, "class"))
    if classes.ndim != 1 or len(classes) != n:
        raise ValueError(f"objects['class'] must have {n} entries, got shape {classes.shape}")
    if classes.dtype.kind in "iu":
        bad = (classes < 0) | (classes >= len(CLASS_NAMES))
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(f"objects['class'][{i}]: class code {classes[i]} is unknown (0..{len(CLASS_NAMES) - 1})")
        codes = classes.astype(np.uint8)
    elif classes.dtype.kind in "USO":
        class_list = classes.tolist()
        try:
            codes = np.fromiter((_CLASS_CODES[c] for c in class_list), dtype=np.uint8, count=n)
        except (KeyError, TypeError):
            i, bad = next((i, c) for i, c in enumerate(class_list) if not isinstance(c, str) or c not in _CLASS_CODES)
            known = ", ".join(CLASS_NAMES)
            raise ValueError(f"objects['class'][{i}]: unknown class {bad!r} (known: {known})") from None
    else:
        raise ValueError(f"objects['class'] must be class names or codes, got dtype {classes.dtype}")
    state = np.empty((n, 6), dtype=np.float32)
    for j, name in enumerate(_STATE_COLUMNS):
        state[:, j] = _real(_column(objects, name), name, n)
    unc = _column(objects, "uncertainty") if "uncertainty" in names else None
    has = None
    if unc is not None:
        u = np.asarray(unc)
        if u.dtype == object:
            # A DataFrame column of per-row arrays.
            try:
                u = np.stack([np.asarray(r, dtype=np.float64) for r in u]) if n else np.zeros((0, 6))
            except ValueError as e:
                raise ValueError(f"objects['uncertainty']: {e}") from None
        if u.dtype.kind not in "fiu" or u.shape != (n, 6):
            raise ValueError(
                f"objects['uncertainty'] must be real numbers of shape ({n}, 6) (one-sigma x, y, heading, speed, "
                f"length, width), got dtype {u.dtype} and shape {u.shape}"
            )
        unc = np.ascontiguousarray(u, dtype=np.float32)
        has = ~np.isnan(unc).all(axis=1)
    return {"ids": ids, "classes": codes, "state": state, "uncertainty": unc, "has_uncertainty": has}


def pose(world_from_ego: Any) -> tuple:
    """``(x_m, y_m, yaw_rad)``; ``None`` is the identity (plausibility then runs ego-relative)."""
    if world_from_ego is None:
        return (0.0, 0.0, 0.0)
    try:
        x, y, yaw = (float(v) for v in world_from_ego)
    except (TypeError, ValueError):
        raise ValueError(f"world_from_ego must be (x_m, y_m, yaw_rad), got {world_from_ego!r}") from None
    return (x, y, yaw)


def extrinsic(ego_from_sensor: Any) -> Optional[np.ndarray]:
    """``None`` (identity) or the ``(3, 4)`` float32 ``[R | t]`` of a ``(4, 4)`` or ``(3, 4)`` matrix."""
    if ego_from_sensor is None:
        return None
    m = np.asarray(ego_from_sensor)
    if m.dtype.kind not in "fiu" or m.shape not in ((4, 4), (3, 4)):
        raise ValueError(f"ego_from_sensor must be a (4, 4) or (3, 4) matrix, got dtype {m.dtype}, shape {m.shape}")
    return np.ascontiguousarray(m[:3], dtype=np.float32)


def polygon_list(polys: Any, name: str) -> list:
    """Polygons in the ego frame as ``(K, 2)`` float32 arrays."""
    if polys is None:
        return []
    if isinstance(polys, np.ndarray) and polys.ndim == 2:
        polys = [polys]
    out = []
    for i, p in enumerate(polys):
        a = np.asarray(p)
        if a.dtype.kind not in "fiu" or a.ndim != 2 or a.shape[1] != 2:
            raise ValueError(f"{name}[{i}] must be an array of (x, y) vertices, shape (K, 2), got shape {a.shape}")
        out.append(np.ascontiguousarray(a, dtype=np.float32))
    return out


def timestamp(t: Any) -> float:
    try:
        v = float(t)
    except (TypeError, ValueError):
        raise ValueError(f"timestamp_s must be a number of seconds, got {t!r}") from None
    # NaN and infinities are passed on: the monitor answers them with `not_monitored(invalid_timestamp)`.
    return v
