"""Descriptors and training that survive a real hand's sensors: calibration bias and noise.

Two measured weaknesses of the plain descriptors (``tactile-bullet benchmark --protocol
sensor-noise``): a per-joint calibration bias of +-3 deg shifts every FCI pixel by a fixed,
unknown amount that no single-grasp feature can tell from the object's shape, and 1 deg of
noise on each of the 12 final angles is blown up by the signature's normalisation (a
cylinder's nearly flat lines become random curves). Two remedies, used together:

- **Zeroing on the open hand** (:func:`zeroed`). Algorithm 1 starts every grasp from the open
  hand, where the FCI joints sit at 0 rad, and records the whole closing. A calibration bias
  is a constant offset on a joint's readings, so the mean of the first ``reference`` samples
  (before the joints have moved: at 60 Hz the first 5 samples span 83 ms, while J2/J1 wait
  for J3 to stop and J3 has moved < 0.1 deg on average) is that offset, and subtracting it
  from the final angles removes it. The final angles are then each joint's mean over the
  plateau it settled on (:func:`settled`: at least the last ``tail`` samples, back to
  ``PLATEAU_SAMPLES``, while the samples stay within 3 noise sigmas of the last ones): a
  finger that stopped early is averaged over up to 40 samples, which divides the noise by up
  to sqrt(40), one still moving at the end over 3. On a real hand this holds where the
  open pose is a mechanical reference (J1/J2 at their 0 rad stops); where the position
  controller itself reads the biased sensor (J3), the open pose inherits the bias and zeroing
  cannot see it: the simulated gain is then an upper bound for J3.
- **Noise-aware training** (:func:`augment`): every training record is also presented
  ``copies`` times read through a :class:`~tactile_bullet.learn.perturb.SensorModel`, so the
  classifier's margins are as wide as the sensor noise it will meet.

Registered descriptors (default plugin): ``robust-signature`` (the signature of the zeroed,
plateau-averaged final angles) and ``robust-joints`` (raw-joints on them). Both need the time
series (records loaded with ``full=True``; recordings with at least ``reference + tail``
samples).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from typing import ClassVar

import numpy as np

from ..errors import UsageError
from ..records import GraspRecord
from .descriptors import (
    SIGNATURE_FLOOR,
    SIGNATURE_LINE_POINTS,
    RawJointsDescriptor,
    SignatureDescriptor,
    check_records,
)
from .perturb import SensorModel, perturb_all

REFERENCE_SAMPLES = 5
"""Samples at the start of a grasp averaged into each joint's zero (the open hand)."""
TAIL_SAMPLES = 3
"""Samples at the end always averaged into the final angles."""
PLATEAU_SAMPLES = 40
"""Longest settled stretch averaged (0.67 s at 60 Hz)."""
AUGMENT_MODEL = SensorModel.degrees(sigma=1.0)
"""Noise-aware training's default sensor model: 1 deg of joint noise (the bias needs no
augmentation once zeroed)."""
AUGMENT_COPIES = 4


def _check_count(value, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not 1 <= value <= 60:
        raise UsageError(f"{what} must be an integer from 1 to 60, got {value!r}")
    return int(value)


def has_series(record, reference: int = REFERENCE_SAMPLES, tail: int = TAIL_SAMPLES) -> bool:
    """Whether ``record`` carries the time series :func:`zeroed` needs (a recording of final
    configurations only, or records read without their series, do not)."""
    angles = np.asarray(record.angles)
    return angles.ndim == 2 and len(angles) >= reference + tail


def zeroed(
    record: GraspRecord, reference: int = REFERENCE_SAMPLES, tail: int = TAIL_SAMPLES
) -> GraspRecord:
    """The record with every joint's open-hand reading subtracted (series and final angles)
    and the final angles replaced by each joint's settled plateau (:func:`settled`)."""
    reference = _check_count(reference, "reference samples")
    tail = _check_count(tail, "tail samples")
    angles = np.asarray(record.angles, dtype=float)
    if not has_series(record, reference, tail):
        raise UsageError(
            f"zeroing needs the grasp's time series (at least {reference + tail} samples, "
            f"got {len(angles)}): load records with their series"
        )
    zero = angles[:reference].mean(axis=0)
    final = settled(angles, tail)
    return replace(record, angles=angles - zero, final_angles=final - zero)


def angles_for_shape_fit(record: GraspRecord) -> np.ndarray:
    """(3, 4) J3/J2/J1 angles of a whole record as the shape-fit coefficients in force were
    fitted: zeroed on the open hand where a hand calibration came from ``calibrate --zeroed``
    (raw angles there would put the sensors' offsets into the fit as shape), raw otherwise.
    Every reader of a whole record (the doubt cross-check, the rotation estimate, ``grasp``'s
    fit) goes through it; descriptor columns say their own (raw-joints or robust-joints)."""
    from ..perception.shape_model import active_calibration

    if active_calibration().angles == "zeroed":
        record = zeroed(record)
    return record.fci_angles()


def settled(series: np.ndarray, tail: int = TAIL_SAMPLES, longest: int = PLATEAU_SAMPLES):
    """Each column's mean over the plateau that ends the series: the last ``tail`` samples,
    extended back while each earlier sample lies within 3 noise sigmas of their mean (sigma
    from the median second difference, robust to the motion; an exact plateau when the data
    are noiseless), up to ``longest`` samples. Measured on the thesis preset (70/30 split,
    signature + svm trained noise-aware, sigma 1 + bias 3 deg): 96.8% against 94.5% for the
    plain mean of the last 3 samples."""
    series = np.asarray(series, dtype=float)
    n = len(series)
    tail = min(tail, n)
    ref = series[-tail:].mean(axis=0)
    if n < 4:
        return ref
    sigma = np.median(np.abs(np.diff(series, n=2, axis=0)), axis=0) / 0.6745 / np.sqrt(6.0)
    earlier = series[::-1][tail : min(longest, n)]  # the samples before the tail, newest first
    outside = np.abs(earlier - ref) > 3.0 * sigma + 1e-4
    # samples kept per column: up to (not including) the first one off the plateau
    extra = np.where(outside.any(axis=0), outside.argmax(axis=0), len(earlier))
    out = np.empty(series.shape[1])
    for col, k in enumerate(extra):
        out[col] = series[n - tail - k :, col].mean()
    return out


def augment(
    records: Sequence[GraspRecord],
    model: SensorModel = AUGMENT_MODEL,
    copies: int = AUGMENT_COPIES,
    seed: int = 0,
) -> list[GraspRecord]:
    """The records followed by ``copies`` perturbed copies of each (seeded): noise-aware
    training data. Labels stay those of the originals."""
    copies = int(copies)
    if copies < 0:
        raise UsageError(f"augmentation copies must be >= 0, got {copies}")
    out = list(records)
    for i in range(copies):
        out += perturb_all(records, model, seed=int(seed) * 1000 + i + 1)
    return out


class _OnZeroedRecords:
    """A descriptor that reads :func:`zeroed` records through an inner one (``_inner``);
    subclasses are frozen dataclasses with ``reference`` and ``tail`` fields."""

    name: ClassVar[str]
    reference: int
    tail: int

    def _inner(self):
        raise NotImplementedError

    def __post_init__(self) -> None:
        self._inner()  # validates the inner descriptor's own options
        _check_count(self.reference, f"{self.name} reference")
        _check_count(self.tail, f"{self.name} tail")

    @property
    def params(self) -> dict:
        return asdict(self)

    def feature_names(self) -> list[str]:
        return self._inner().feature_names()

    def transform(self, records) -> np.ndarray:
        items = check_records(records)
        return self._inner().transform([zeroed(r, self.reference, self.tail) for r in items])


@dataclass(frozen=True)
class RobustSignatureDescriptor(_OnZeroedRecords):
    """The signature descriptor on :func:`zeroed` records."""

    points: int = SIGNATURE_LINE_POINTS
    floor: float = SIGNATURE_FLOOR
    reference: int = REFERENCE_SAMPLES
    tail: int = TAIL_SAMPLES
    name: ClassVar[str] = "robust-signature"

    def _inner(self) -> SignatureDescriptor:
        return SignatureDescriptor(points=self.points, floor=self.floor)


@dataclass(frozen=True)
class RobustJointsDescriptor(_OnZeroedRecords):
    """The raw-joints descriptor on :func:`zeroed` records."""

    include_thumb: bool = False
    reference: int = REFERENCE_SAMPLES
    tail: int = TAIL_SAMPLES
    name: ClassVar[str] = "robust-joints"

    def _inner(self) -> RawJointsDescriptor:
        return RawJointsDescriptor(self.include_thumb)


@dataclass(frozen=True)
class RobustCoupledJointsDescriptor(_OnZeroedRecords):
    """The coupled-joints descriptor on :func:`zeroed` records: per long finger J4, J3 and
    J0 = J1 + J2 (LF J5 first), each joint's open-hand reading subtracted and its plateau
    averaged. Neither a calibration bias nor the tendon's split of J0 reaches it, and it reads
    the hand through other features than the finger points: a second opinion whose mistakes
    are not the default's (``learn/second_opinion.py``)."""

    reference: int = REFERENCE_SAMPLES
    tail: int = TAIL_SAMPLES
    name: ClassVar[str] = "robust-coupled-joints"

    def _inner(self):
        from .coupled import CoupledJointsDescriptor

        return CoupledJointsDescriptor()
