"""How a sweep TOML gives a quantity: one number, a list of numbers, or a ``{min, max}`` range
(read once here for the grasp dimensions of ``sweeps`` and the per-grasp draws of
``[randomize]``)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..errors import UsageError

Values = tuple[float, ...] | dict[str, float]
"""A list of values (a tuple) or a range ``{"min", "max"}`` (plus ``steps`` in grid mode)."""


def _number(value: Any) -> bool:
    """A TOML integer or float (a boolean is neither, though Python counts it an int)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


def numbers_or_range(value: Any, what: str, keys: Sequence[str] = ("min", "max")) -> Values:
    """``value`` as a tuple of finite floats or a ``{"min", "max"}`` range with min <= max;
    a range may hold only ``keys`` (extra keys, e.g. a grid's ``steps``, are the caller's)."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        value = [value]
    if isinstance(value, list):
        if not value or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            for v in value
        ):
            raise UsageError(f"{what} must be a non-empty list of numbers or a {{min, max}} table")
        return tuple(float(v) for v in value)
    if isinstance(value, Mapping):
        unknown = sorted(set(value) - set(keys))
        if unknown or not {"min", "max"} <= set(value):
            raise UsageError(f"{what} range takes the keys {', '.join(keys)} (min and max needed)")
        if not all(_number(value[k]) for k in ("min", "max")):  # "0.5" or true is no number
            raise UsageError(f"{what} range needs numeric min and max, got "
                             f"{value['min']!r} and {value['max']!r}")  # fmt: skip
        lo, hi = float(value["min"]), float(value["max"])
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
            raise UsageError(f"{what} range needs finite min <= max, got {lo:g} > {hi:g}")
        return {"min": lo, "max": hi}
    raise UsageError(f"{what} must be a list of numbers or a {{min, max}} table")
