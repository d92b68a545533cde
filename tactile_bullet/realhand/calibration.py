"""Joint-space calibration of a real hand: per-joint offset and scale, read from TOML.

A real Shadow hand's joint sensors drift from the simulated hand's zero and gain (Hall-effect
sensors calibrated months ago, a tendon that stretched). The signature reads absolute phalanx
angles, so a few degrees of offset on J3 move the whole lower line; this file lets the user
correct each joint before a recording is turned into grasp records::

    # calibrated = scale * published + offset   (offset in rad, or offset_deg in degrees)
    [joints]
    FFJ3 = { offset = 0.02 }
    rh_MFJ0 = { offset_deg = -1.5, scale = 1.03 }

Keys are joint names as the hand publishes them (prefix optional, ``FFJ0`` for the coupled
joint of a hand that publishes it): the correction applies to the sensor, before J0 is split.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import read_toml

ENTRY_KEYS = ("offset", "offset_deg", "scale")
MAX_OFFSET = math.pi / 2
"""A larger offset is a wrong sign convention or a wrong joint, not a drift."""
SCALE_RANGE = (0.5, 2.0)


@dataclass(frozen=True)
class Calibration:
    """Offsets (rad) and scales by canonical published joint name (``FFJ3``, ``FFJ0``)."""

    offsets: Mapping[str, float] = field(default_factory=dict)
    scales: Mapping[str, float] = field(default_factory=dict)
    prefix: str = ""
    """The hand prefix its entries name (``rh``), "" when they name none: a recording of
    another hand is refused rather than corrected with this hand's numbers."""

    def vectors(self, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
        """(scale, offset) arrays aligned with canonical ``names``: identity where absent."""
        scale = np.array([self.scales.get(n, 1.0) for n in names], float)
        offset = np.array([self.offsets.get(n, 0.0) for n in names], float)
        return scale, offset

    def to_dict(self) -> dict[str, dict[str, float]]:
        names = sorted(set(self.offsets) | set(self.scales))
        return {
            n: {"offset": float(self.offsets.get(n, 0.0)), "scale": float(self.scales.get(n, 1.0))}
            for n in names
        }


def calibration_from_dict(doc: Mapping, source: str = "calibration") -> Calibration:
    """Validate a ``{"joints": {name: {offset|offset_deg, scale}}}`` table."""
    from .names import canonical_joint, split_name

    if not isinstance(doc, Mapping) or set(doc) - {"joints"}:
        extra = sorted(set(doc) - {"joints"}) if isinstance(doc, Mapping) else ["?"]
        raise UsageError(f"{source}: unknown key {extra[0]!r} (expected a [joints] table)")
    joints = doc.get("joints", {})
    if not isinstance(joints, Mapping):
        raise UsageError(f"{source}: [joints] must be a table")
    offsets: dict[str, float] = {}
    scales: dict[str, float] = {}
    prefixes: set[str] = set()
    for raw_name, entry in joints.items():
        name = canonical_joint(raw_name)
        if name is None:
            raise UsageError(f"{source}: unknown joint {raw_name!r}")
        hand = split_name(raw_name)[0].lower()
        if hand and prefixes and hand not in prefixes:
            raise UsageError(
                f"{source}: joints.{raw_name} is for hand {hand!r}, an earlier entry for "
                f"{sorted(prefixes)[0]!r}: one hand per calibration file"
            )
        if hand:
            prefixes.add(hand)
        if not isinstance(entry, Mapping):
            raise UsageError(
                f"{source}: joints.{raw_name} must be a table like {{ offset = 0.01 }}"
            )
        unknown = sorted(set(entry) - set(ENTRY_KEYS))
        if unknown:
            raise UsageError(
                f"{source}: joints.{raw_name}: unknown key {unknown[0]!r} "
                f"(keys: {', '.join(ENTRY_KEYS)})"
            )
        if "offset" in entry and "offset_deg" in entry:
            raise UsageError(f"{source}: joints.{raw_name}: give offset or offset_deg, not both")
        offset = _number(entry.get("offset", 0.0), f"{source}: joints.{raw_name}.offset")
        if "offset_deg" in entry:
            offset = math.radians(_number(entry["offset_deg"], f"{source}: joints.{raw_name}"))
        scale = _number(entry.get("scale", 1.0), f"{source}: joints.{raw_name}.scale")
        if abs(offset) > MAX_OFFSET:
            raise UsageError(
                f"{source}: joints.{raw_name} offset {offset:.3f} rad is over {MAX_OFFSET:.2f}"
            )
        if not SCALE_RANGE[0] <= scale <= SCALE_RANGE[1]:
            raise UsageError(
                f"{source}: joints.{raw_name} scale {scale} is outside {SCALE_RANGE[0]}.."
                f"{SCALE_RANGE[1]}"
            )
        if name in offsets:
            raise UsageError(f"{source}: joint {name} is calibrated twice")
        offsets[name], scales[name] = offset, scale
    return Calibration(offsets, scales, next(iter(prefixes), ""))


def _number(value, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise UsageError(f"{what} must be a finite number, got {value!r}")
    return float(value)


def load_calibration(path: str | Path) -> Calibration:
    """Read a calibration TOML file (see the module docstring)."""
    path = Path(path)
    doc = read_toml(path, "calibration file")
    return calibration_from_dict(doc, str(path))
