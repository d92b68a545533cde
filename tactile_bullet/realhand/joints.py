"""Shadow's published joint names, the coupled J0, and the samples every reader produces.

A real hand publishes ``FFJ3`` or ``rh_FFJ3`` (one prefix per recording), and some drivers the
coupled ``FFJ0`` (= J1 + J2) instead of J1 and J2: :class:`JointMap` maps a published name list
onto the record's columns once, then applies it to every message with numpy indexing.
:class:`JointSamples` is what the bag and table readers both return.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import UsageError
from ..hand import JOINT_NAMES, LONG_FINGERS, joint_range
from .calibration import Calibration
from .names import COUPLED_FINGERS, OPTIONAL_JOINTS, split_name

J2_MAX = math.pi / 2
"""Travel J2 takes from J0 before the rest goes to J1 (the joint's limit)."""
_COLUMN = {name: i for i, name in enumerate(JOINT_NAMES)}
_CLOSURE = np.array([_COLUMN[f"{f.upper()}J{k}"] for f in LONG_FINGERS for k in (3, 2, 1)])


class JointMap:
    """How one list of published joint names maps onto the record's columns (JOINT_NAMES).

    Built once per distinct name list (a driver publishes the same list every message), then
    applied to each message's (or a whole table's) positions and efforts with a few numpy
    indexing operations. ``calibration`` corrects the sensors before J0 is split.
    """

    def __init__(
        self, names: Sequence[str], calibration: Calibration | None = None, where: str = ""
    ) -> None:
        self.names = tuple(str(n) for n in names)
        where = f"{where}: " if where else ""
        parts = [split_name(n) for n in self.names]
        unknown = [n for n, p in zip(self.names, parts, strict=True) if p is None]
        if unknown:
            shown = ", ".join(n if n.isascii() else f"{ascii(n)} (not ASCII)" for n in unknown)
            raise UsageError(f"{where}unknown joint names: {shown}")
        prefixes = sorted({p[0] for p in parts if p is not None})
        if len(prefixes) > 1:
            shown = ", ".join(repr(p or "(none)") for p in prefixes)
            raise UsageError(f"{where}joint names mix hand prefixes {shown}: one hand per file")
        canon = [p[1] for p in parts if p is not None]
        seen: set[str] = set()
        dup = [c for c in canon if c in seen or seen.add(c)]
        if dup:
            raise UsageError(f"{where}joint {dup[0]} appears twice")
        self.prefix = prefixes[0] if prefixes else ""
        self.canonical = tuple(canon)
        index = {c: i for i, c in enumerate(canon)}
        direct_src, direct_dst, j0_src, j2_dst, j1_dst = [], [], [], [], []
        missing = []
        for name in JOINT_NAMES:
            if name in index:
                direct_src.append(index[name])
                direct_dst.append(_COLUMN[name])
        for f in COUPLED_FINGERS:
            up = f.upper()
            j0 = f"{up}J0"
            if f"{up}J1" in index and f"{up}J2" in index:
                continue
            if j0 in index and f"{up}J1" not in index and f"{up}J2" not in index:
                j0_src.append(index[j0])
                j2_dst.append(_COLUMN[f"{up}J2"])
                j1_dst.append(_COLUMN[f"{up}J1"])
        covered = {JOINT_NAMES[c] for c in direct_dst + j2_dst + j1_dst}
        missing = [n for n in JOINT_NAMES if n not in covered and n not in OPTIONAL_JOINTS]
        if missing:
            shown = ", ".join(self.prefix + "_" + m if self.prefix else m for m in missing)
            raise UsageError(f"{where}missing joints: {shown}")
        self.coupled = bool(j0_src)
        self._src = np.array(direct_src, int)
        self._dst = np.array(direct_dst, int)
        self._j0 = np.array(j0_src, int)
        self._j2 = np.array(j2_dst, int)
        self._j1 = np.array(j1_dst, int)
        calibration = calibration or Calibration()
        if calibration.prefix and calibration.prefix != self.prefix.lower():
            raise UsageError(
                f"{where}the calibration is for hand prefix {calibration.prefix!r}, the "
                f"recording's joints carry {self.prefix or '(none)'!r}: one hand per file"
            )
        self._scale, self._offset = calibration.vectors(self.canonical)
        self._identity = bool(np.all(self._scale == 1.0) and np.all(self._offset == 0.0))
        ranges = np.array([joint_range(c) for c in canon], float).reshape(-1, 2)
        self._lo, self._hi = ranges[:, 0], ranges[:, 1]
        self._where = where  # "FILE: ", ready to prefix a message

    def positions(self, raw: np.ndarray, time: np.ndarray | float | None = None) -> np.ndarray:
        """Published positions (..., k) -> record angles (..., 24): calibrated, checked
        against the hand's ranges (:meth:`check_range`; ``time`` (...) names the sample in
        the error), J0 split."""
        raw = np.asarray(raw, float)
        if not self._identity:
            raw = raw * self._scale + self._offset
        self.check_range(raw, time)
        out = np.zeros(raw.shape[:-1] + (len(JOINT_NAMES),))
        out[..., self._dst] = raw[..., self._src]
        if self.coupled:
            j0 = raw[..., self._j0]
            j2 = np.clip(j0, 0.0, J2_MAX)
            out[..., self._j2] = j2
            out[..., self._j1] = j0 - j2
        return out

    def check_range(self, calibrated: np.ndarray, time: np.ndarray | float | None) -> None:
        """Refuse a calibrated position that is NaN, infinite, or outside its joint's range
        plus ``hand.RANGE_TOLERANCE_RAD`` (docs/hand.md): no hand can be there, so any shape
        answered from it would be nonsense. The error names the joint, the time and the
        value."""
        values = np.asarray(calibrated, float).reshape(-1, len(self.names))
        bad = ~((values >= self._lo) & (values <= self._hi))  # NaN fails both
        if not bad.any():
            return
        row, col = (int(v) for v in np.argwhere(bad)[0])
        value = values[row, col]
        when = ""
        if time is not None:
            t = np.asarray(time, float).reshape(-1)
            when = f" at {float(t[row] if t.size > row else t[0]):.6g} s"
        label = "calibrated value" if not self._identity else "value"
        problem = "not a number" if np.isnan(value) else (
            f"outside the hand's range {self._lo[col]:.3f} .. {self._hi[col]:.3f} rad "
            "(joint limits plus tolerance, docs/hand.md)"
        )  # fmt: skip
        raise UsageError(
            f"{self._where}joint {self.names[col]}{when}: "
            f"{label} {value:.6g} rad is {problem}"
        )

    def efforts(self, raw: np.ndarray) -> np.ndarray:
        """Published efforts (..., k) -> record efforts (..., 24); the tendon's J0 effort acts
        on both J2 and J1, so both columns get it."""
        raw = np.asarray(raw, float)
        out = np.zeros(raw.shape[:-1] + (len(JOINT_NAMES),))
        out[..., self._dst] = raw[..., self._src]
        if self.coupled:
            out[..., self._j2] = raw[..., self._j0]
            out[..., self._j1] = raw[..., self._j0]
        return out


def closure(angles: np.ndarray) -> np.ndarray:
    """How far the hand has closed: mean over the long fingers of J3 + J2 + J1 (rad)."""
    return np.asarray(angles)[..., _CLOSURE].sum(axis=-1) / len(LONG_FINGERS)


# --- the common intermediate: joint samples ---------------------------------------------------


@dataclass
class JointSamples:
    """A recording as arrays in record columns.

    ``time`` (n,) s from the first sample (header stamps); ``receive`` (n,) s on the marker's
    clock (bag receive time; the table's time column); ``windows`` grasps marked in the file
    as (start, end, label) on the ``receive`` clock, or None when the file marks none."""

    source: str
    time: np.ndarray
    receive: np.ndarray
    angles: np.ndarray
    efforts: np.ndarray
    has_efforts: bool
    windows: list[tuple[float, float, str | None]] | None = None
    row_groups: np.ndarray | None = None
    """Tables: per row, the marker column's grasp key (0 between grasps)."""
    labels: list[str | None] = field(default_factory=list)
    objects: list[str | None] = field(default_factory=list)
    """Tables: per row, the ``object`` column's value (None where empty or absent)."""
    coupled: bool = False
    prefix: str = ""


def _check_time(time: np.ndarray, where: str) -> None:
    if time.size == 0:
        raise UsageError(f"{where}: no joint-state samples")
    if not np.all(np.isfinite(time)):
        raise UsageError(f"{where}: time holds NaN or infinity")
    steps = np.diff(time)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        k = int(bad[0])
        raise UsageError(
            f"{where}: time is not increasing at sample {k + 1} "
            f"({time[k]:.6f} s then {time[k + 1]:.6f} s)"
        )


def _check_finite(values: np.ndarray, where: str, what: str) -> None:
    if not np.all(np.isfinite(values)):
        row = int(np.flatnonzero(~np.all(np.isfinite(values), axis=-1))[0])
        raise UsageError(f"{where}: {what} hold NaN or infinity at sample {row}")
