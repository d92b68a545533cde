"""Descriptors that do not assume how the J1/J2 tendon splits its travel.

The Shadow hand's middle (J2) and distal (J1) joints share one tendon: what the hand controls,
and what some drivers publish, is J0 = J1 + J2. How J0 divides between the two depends on the
tendon, the friction in it, which phalanx touches first, and the simulator: our controller
gives J2 first; a model with one actuator of equal torque on both curls the distal joint first
(issue 19). A descriptor that reads J2 and J1 apart learns our split; on another hand it reads
a different split of the same closure as another shape. A recording that publishes only J0 is
imported with J2 taking it first (``realhand/joints.py``), a split the hand never reported.

These descriptors first re-split every long finger's J0 evenly (:func:`coupled_record`:
J2 = J1 = (J1 + J2) / 2, in the final angles and the whole series; both efforts their mean),
so they depend on J3 and J0 only, and give identical features for any split of the same J0,
a J0-only recording included:

- ``coupled-signature``: the signature (``learn/descriptors.py``) of the re-split angles. Its
  lower line is J3's and its upper line J3 + J0's, as in the plain signature; only the cubic
  upscaling's overshoot, which reads the middle row J3 + J2, changes.
- ``coupled-joints``: raw-joints with J0 in place of J2 and J1 (J4, J3, J0 per finger, LF J5).
- ``coupled-time-series``: the time series of the re-split record.

What they give up, and where each breaks, is measured in ``docs/transfer.md``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import asdict, dataclass
from typing import ClassVar

import numpy as np

from ..errors import UsageError
from ..hand import LONG_FINGERS
from ..records import GraspRecord
from .descriptors import SignatureDescriptor, check_records
from .time_series import TimeSeriesDescriptor


def _pairs(record: GraspRecord) -> tuple[list[int], list[int]]:
    """Record columns of each long finger's J2 and J1."""
    j2 = [record.joint_index(f"{f.upper()}J2") for f in LONG_FINGERS]
    j1 = [record.joint_index(f"{f.upper()}J1") for f in LONG_FINGERS]
    return j2, j1


def coupled_record(record: GraspRecord) -> GraspRecord:
    """The record with each long finger's J0 = J1 + J2 split evenly between J2 and J1 (angles,
    final angles, every sample) and both efforts set to their mean: what is left of a grasp
    once the split is forgotten."""
    j2, j1 = _pairs(record)

    def even(values: np.ndarray) -> np.ndarray:
        values = np.array(values, dtype=float, copy=True)
        mean = 0.5 * (values[..., j2] + values[..., j1])
        values[..., j2] = mean
        values[..., j1] = mean
        return values

    return dataclasses.replace(
        record,
        angles=even(record.angles) if np.ndim(record.angles) == 2 else record.angles,
        efforts=even(record.efforts) if np.ndim(record.efforts) == 2 else record.efforts,
        final_angles=even(record.final_angles),
    )


def j0_only(record: GraspRecord) -> GraspRecord:
    """The record as a hand that publishes only J0 is imported today (``realhand/joints.py``):
    J2 takes J0 up to its limit, J1 the rest; efforts both the tendon's (their mean here). For
    measuring how a descriptor depends on the split (``benchmarks/bench_coupling.py``)."""
    from ..realhand.joints import J2_MAX

    j2, j1 = _pairs(record)

    def first(values: np.ndarray, efforts: bool) -> np.ndarray:
        values = np.array(values, dtype=float, copy=True)
        if efforts:
            mean = 0.5 * (values[..., j2] + values[..., j1])
            values[..., j2] = values[..., j1] = mean
            return values
        j0 = values[..., j2] + values[..., j1]
        values[..., j2] = np.clip(j0, 0.0, J2_MAX)
        values[..., j1] = j0 - values[..., j2]
        return values

    return dataclasses.replace(
        record,
        angles=first(record.angles, False) if np.ndim(record.angles) == 2 else record.angles,
        efforts=first(record.efforts, True) if np.ndim(record.efforts) == 2 else record.efforts,
        final_angles=first(record.final_angles, False),
    )


@dataclass(frozen=True)
class CoupledSignatureDescriptor(SignatureDescriptor):
    """The signature of :func:`coupled_record`: J3 and J0 only."""

    name: ClassVar[str] = "coupled-signature"

    def transform(self, records) -> np.ndarray:
        return super().transform([coupled_record(r) for r in check_records(records)])


def coupled_joint_names() -> list[str]:
    """Joints of coupled-joints: per long finger J4, J3 and the coupled J0 (LF J5 first)."""
    names = []
    for finger in LONG_FINGERS:
        up = finger.upper()
        names += ([f"{up}J5"] if finger == "lf" else []) + [f"{up}J4", f"{up}J3", f"{up}J0"]
    return names


@dataclass(frozen=True)
class CoupledJointsDescriptor:
    """Final angles (rad) of the long fingers with J0 = J1 + J2 in place of J2 and J1."""

    name: ClassVar[str] = "coupled-joints"

    @property
    def params(self) -> dict:
        return asdict(self)

    def feature_names(self) -> list[str]:
        return coupled_joint_names()

    def transform(self, records) -> np.ndarray:
        items = check_records(records)
        names = self.feature_names()
        out = np.empty((len(items), len(names)))
        for row, record in enumerate(items):
            values = []
            for name in names:
                if name.endswith("J0"):
                    values.append(record.final(name[:2] + "J1") + record.final(name[:2] + "J2"))
                else:
                    values.append(record.final(name))
            out[row] = values
        return out


@dataclass(frozen=True)
class CoupledTimeSeriesDescriptor(TimeSeriesDescriptor):
    """The time series of :func:`coupled_record` (J2 and J1 channels both carry J0 / 2)."""

    name: ClassVar[str] = "coupled-time-series"

    def transform(self, records) -> np.ndarray:
        items = check_records(records)
        for row, record in enumerate(items):
            if np.ndim(record.angles) != 2:
                raise UsageError(f"record {row} ({record.shape}) has no time series")
        return super().transform([coupled_record(r) for r in items])
