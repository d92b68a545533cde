"""The ``time-series`` descriptor: the whole grasp as joint-angle and effort series.

The signature keeps only the final configuration of the FCI joints; a learned model over the
whole closing motion (when each finger met the object, how its effort rose) may see more.
Each record's series is resampled to ``length`` evenly spaced instants between its first and
last sample (linear interpolation on the record's own time stamps), so grasps of different
durations, sample rates or lengths give the same layout: time is normalised to the grasp's
duration, which also makes the features independent of the closing speed.

Channels, in this fixed order whatever the record's column order (joints are looked up by
name, so a real hand's recording with its own column order works as long as it names the
joints): the angles (rad) of ``time_series_joints(include_thumb)``, then, with
``efforts=True``, their efforts (N m) in the same joint order. Features are channel-major:
column ``c * length + i`` is channel ``c`` at instant ``i``, so a row reshapes to
``(channels, length)``, the layout the ``tcn`` classifier reads.

Only numpy: importing it (the CLI's registry) stays cheap.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import ClassVar

import numpy as np

from ..errors import UsageError

TIME_SERIES_LENGTH = 32
"""Default instants per channel. A grasp closes each finger in a few distinct phases (travel,
contact, conforming, settled), which 32 instants resolve; more mostly adds columns."""

MIN_LENGTH, MAX_LENGTH = 2, 512
"""Allowed ``length`` range: at least start and end; 512 x 44 channels is already 22,528
features per grasp."""


def time_series_joints(include_thumb: bool = False) -> list[str]:
    """Joints of the descriptor, in channel order: the four long fingers' J4..J1 (LF J5..J1),
    then the thumb's J5..J1 with ``include_thumb`` (off by default: the thumb is held at a
    fixed opposed pose and moves little; its effort still tells when the object pushed it)."""
    from .descriptors import raw_joint_names

    return raw_joint_names(include_thumb)


def channel_names(include_thumb: bool = False, efforts: bool = True) -> list[str]:
    """Channel names: ``angle:FFJ4`` ... then ``effort:FFJ4`` ..."""
    joints = time_series_joints(include_thumb)
    names = [f"angle:{j}" for j in joints]
    if efforts:
        names += [f"effort:{j}" for j in joints]
    return names


def resample_series(
    time: np.ndarray, values: np.ndarray, length: int, what: str = "record"
) -> np.ndarray:
    """(T, C) samples at ``time`` -> (C, length) at evenly spaced instants over [t0, t_end].

    A single sample is held constant; time stamps that do not increase (a recording that
    restarted its clock) fall back to the sample index, which keeps the order of samples.
    """
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or values.shape[0] == 0:
        raise UsageError(f"{what} has no time series to resample (shape {values.shape})")
    if not np.all(np.isfinite(values)):
        raise UsageError(f"{what} has non-finite values in its time series")
    if values.shape[0] == 1:
        return np.repeat(values.T, length, axis=1)
    t = np.asarray(time, dtype=float).reshape(-1)
    if t.shape[0] != values.shape[0] or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        t = np.arange(values.shape[0], dtype=float)
    grid = np.linspace(t[0], t[-1], length)
    right = np.clip(np.searchsorted(t, grid, side="right"), 1, len(t) - 1)
    left = right - 1
    w = ((grid - t[left]) / (t[right] - t[left]))[:, None]
    out = values[left] * (1.0 - w) + values[right] * w
    return out.T


@dataclass(frozen=True)
class TimeSeriesDescriptor:
    """Joint angles (and efforts) of the grasp over normalised time, channel-major."""

    length: int = TIME_SERIES_LENGTH
    efforts: bool = True
    include_thumb: bool = False
    name: ClassVar[str] = "time-series"

    def __post_init__(self) -> None:
        if isinstance(self.length, bool) or not isinstance(self.length, int | np.integer):
            raise UsageError(f"time-series length must be an integer, got {self.length!r}")
        if not MIN_LENGTH <= self.length <= MAX_LENGTH:
            raise UsageError(
                f"time-series length must be from {MIN_LENGTH} to {MAX_LENGTH}, got {self.length}"
            )
        for flag in ("efforts", "include_thumb"):
            if not isinstance(getattr(self, flag), bool | np.bool_):
                raise UsageError(
                    f"time-series {flag} must be true or false, got {getattr(self, flag)!r}"
                )

    @property
    def params(self) -> dict:
        return asdict(self)

    def channels(self) -> list[str]:
        return channel_names(bool(self.include_thumb), bool(self.efforts))

    def feature_names(self) -> list[str]:
        return [f"{c}@{i:03d}" for c in self.channels() for i in range(self.length)]

    def transform(self, records) -> np.ndarray:
        from .descriptors import check_records

        items = check_records(records)
        joints = time_series_joints(bool(self.include_thumb))
        n_channels = len(self.channels())
        out = np.empty((len(items), n_channels * self.length))
        for row, record in enumerate(items):
            cols = [record.joint_index(j) for j in joints]
            series = [np.asarray(record.angles, dtype=float)]
            if self.efforts:
                series.append(np.asarray(record.efforts, dtype=float))
            for block in series:
                if block.ndim != 2 or block.shape[1] != len(record.joint_names):
                    raise UsageError(
                        f"record {row} ({record.shape}) has a time series of shape "
                        f"{block.shape} for {len(record.joint_names)} joints"
                    )
            values = np.hstack([block[:, cols] for block in series])
            out[row] = resample_series(
                record.time, values, self.length, f"record {row} ({record.shape})"
            ).reshape(-1)
        return out
