"""Monitor parameters: the paper's Table I by default, validated by the Rust side."""

from __future__ import annotations

import copy
import json
import os
from typing import Any, Mapping, Optional, Union

from . import _pmon

_DEFAULTS: dict = json.loads(_pmon.default_params_json())


class Params:
    """The monitor's parameters, dataclass-like and immutable.

    ``Params()`` is the paper's Table I (the defaults of ``pmon params``). Keyword arguments override any
    subset of the keys; a nested table (``motion_limits``, ``default_uncertainty``, ...) may be given in part,
    its other keys keep their values. Every construction goes through the Rust validation, so an unknown key,
    a wrong type or a value out of range raises ``ValueError`` with the same message as ``pmon check
    --params``. Units are in the names (``_m``, ``_s``, ``_mps``, ``_rad``).

    >>> p = Params(cell_size_m=0.2)
    >>> p.cell_size_m
    0.2
    >>> p.replace(tau_tp=0.8).tau_tp
    0.8
    """

    __slots__ = ("_values",)

    def __init__(self, **overrides: Any) -> None:
        values = json.loads(_pmon.validate_params_json(json.dumps(overrides, allow_nan=False)))
        object.__setattr__(self, "_values", values)

    # -- construction ------------------------------------------------------------------------------------
    @classmethod
    def _from_json(cls, text: str) -> "Params":
        p = cls.__new__(cls)
        object.__setattr__(p, "_values", json.loads(text))
        return p

    @classmethod
    def from_dict(cls, values: Mapping[str, Any], base: Optional["Params"] = None) -> "Params":
        """``values`` (any subset of the keys, nested tables too) over ``base`` (the defaults when ``None``)."""
        if not isinstance(values, Mapping):
            raise ValueError(f"parameters must be a mapping of keys to values, got {type(values).__name__}")
        base_json = None if base is None else base.to_json()
        try:
            text = json.dumps(dict(values), allow_nan=False)
        except (TypeError, ValueError) as e:
            raise ValueError(f"parameters: {e}") from None
        return cls._from_json(_pmon.validate_params_json(text, base_json))

    @classmethod
    def from_toml(cls, path: Union[str, "os.PathLike[str]"], base: Optional["Params"] = None) -> "Params":
        """A TOML file as written by ``pmon params`` (any subset of keys) over ``base``; errors name the file."""
        base_json = None if base is None else base.to_json()
        return cls._from_json(_pmon.params_json_from_toml_file(os.fspath(path), base_json))

    @classmethod
    def profile(cls, name: str, base: Optional["Params"] = None) -> "Params":
        """A parameter profile pmon ships over ``base`` (the defaults when ``None``), as ``pmon check --params
        profile:NAME``: ``Params.profile("recall")`` turns on the three opt-in rules that judge displacements below
        ``dx_min`` by the returns (README, "The recall profile"). :meth:`profiles` lists the names and
        :meth:`profile_text` gives a profile's file, with what it buys and costs. An unknown name raises
        ``ValueError`` listing the profiles there are.

        >>> Params.profiles()
        ['recall']
        >>> r = Params.profile("recall")
        >>> (r.returns_beyond_cells, r.face_in_front, r.seen_over)
        (1, True, True)
        >>> r == Params(returns_beyond_cells=1, face_in_front=True, seen_over=True)
        True
        """
        base_json = None if base is None else base.to_json()
        return cls._from_json(_pmon.profile_params_json(name, base_json))

    @staticmethod
    def profiles() -> list:
        """The names of the parameter profiles pmon ships (for :meth:`profile`)."""
        return list(_pmon.profile_names())

    @staticmethod
    def profile_text(name: str) -> str:
        """The TOML file of a profile, with its comments: what it buys and what it costs, measured."""
        return _pmon.profile_toml(name)

    def replace(self, **changes: Any) -> "Params":
        """A copy with ``changes`` applied (nested tables merge key by key), validated."""
        return Params.from_dict(changes, base=self)

    # -- access ------------------------------------------------------------------------------------------
    def __getattr__(self, name: str) -> Any:
        values = object.__getattribute__(self, "_values")
        if name in values:
            return copy.deepcopy(values[name])
        raise AttributeError(f"Params has no field {name!r} (fields: {', '.join(values)})")

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("Params is immutable: use params.replace(...)")

    def __dir__(self):
        return list(self._values) + [
            "replace", "to_dict", "to_json", "to_toml", "from_dict", "from_toml", "fields", "profile", "profiles",
            "profile_text",
        ]

    @staticmethod
    def fields() -> list:
        """The top-level field names, in the order of ``pmon params``."""
        return list(_DEFAULTS)

    def to_dict(self) -> dict:
        """Every field as plain Python values (nested tables as dicts)."""
        return copy.deepcopy(self._values)

    def to_json(self) -> str:
        return json.dumps(self._values)

    def to_toml(self) -> str:
        """The TOML ``pmon params`` writes (loadable with ``--params`` and :meth:`from_toml`)."""
        return _pmon.params_toml_from_json(self.to_json())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Params) and self._values == other._values

    def __hash__(self) -> int:
        return hash(self.to_json())

    def __repr__(self) -> str:
        changed = {k: v for k, v in self._values.items() if _DEFAULTS.get(k) != v}
        inner = ", ".join(f"{k}={v!r}" for k, v in changed.items())
        return f"Params({inner})"

    def __reduce__(self):
        return (Params.from_dict, (self.to_dict(),))


ParamsLike = Union[None, Params, Mapping[str, Any], str, "os.PathLike[str]"]


def as_params(params: ParamsLike) -> Params:
    """``None`` (Table I), a :class:`Params`, a dict of overrides, the path of a TOML file, or ``"profile:NAME"``
    (a profile pmon ships, as ``--params profile:NAME``; a file of that name is ``"./profile:NAME"``)."""
    if params is None:
        return Params()
    if isinstance(params, Params):
        return params
    if isinstance(params, Mapping):
        return Params.from_dict(params)
    if isinstance(params, (str, os.PathLike)):
        return Params.from_toml(params)
    raise ValueError(
        f"params must be None, a pmon.Params, a dict, the path of a TOML file or 'profile:NAME', "
        f"got {type(params).__name__}"
    )
