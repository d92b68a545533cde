"""Where the fingers are, not how their joints divide the bend: the phalanx ends in space.

The signature's FCI (thesis eq. 2.2) holds each long finger's *cumulative* flexion: phi3 = J3,
phi2 = J3 + J2, phi1 = J3 + J2 + J1, the absolute angle of the proximal, middle and distal
phalanx. ``finger-points`` reads the same three angles through the phalanx lengths of the
hand's sheet (docs/hand.md): the end of phalanx k sits at

    (y, z) = knuckle + sum over i <= k of L_i * (-sin phi_i, cos phi_i)

in the finger's flexion plane (palm frame; y toward the object, z along the fingers). For each
long finger it gives the (y, z) of J2, of J1 and of the fingertip: 24 numbers, in metres.

Why: an enclosure grasp ends with the phalanges *on the object*, so where they end is set by
the object's shape and size, while how a finger's bend divides between J3, J2 and J1 is set
by the hand (servo stiffness, the J1/J2 tendon, the simulator). On one sphere, three Shadow
hands whose joint angles differ by up to 35 deg end their fingertips 2-10 mm apart
(docs/figures.md). Measured over 120 objects (``benchmarks/hand_difference.py``), the points move
from hand to hand about as little as the signature, a quarter to half of their spread across
objects where raw joint angles move one to four spreads; unlike the signature, whose lines are
normalised, they keep the object's size. docs/transfer.md has the accuracies.

``profile=True`` lays the same 24 numbers out as the signature lays out its lines: the mean
over the four fingers of each point's y and z (6 numbers: how far the hand closed, the
object's size) and each finger's deviation from that mean (24: the profile across the
fingers, the shape). It is the same information, but a classifier that scales each feature
to unit spread then weighs the small differences between fingers (a hyperboloid's waist
against a cylinder) as much as the large ones between sizes.

``coupled-finger-points`` does the same on :func:`.coupled.coupled_record` (J2 = J1 = J0 / 2),
for a hand that publishes only J0 = J1 + J2.

The knuckle heights and finger planes are our hand's (``hand.KNUCKLE_Z``); J4 (spread) and
LF J5 (cupping) are taken as 0, as Algorithm 1 leaves them in an enclosure grasp.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import ClassVar

import numpy as np

from ..errors import UsageError
from ..hand import KNUCKLE_Z, LONG_FINGERS
from .coupled import coupled_record
from .descriptors import check_records

PHALANX_ENDS: tuple[float, float, float] = (0.045, 0.025, 0.026)
"""J3 to J2, J2 to J1, J1 to the tip frame (m): the joint origins of docs/hand.md."""

POINTS: tuple[str, ...] = ("j2", "j1", "tip")


def finger_points(fci_angles: np.ndarray) -> np.ndarray:
    """(4, 3, 2) phalanx ends (y, z) in m, per long finger (ff, mf, rf, lf) and point (J2, J1,
    tip), from (3, 4) final angles (rows J3, J2, J1) in rad."""
    angles = np.asarray(fci_angles, dtype=float)
    phi = np.cumsum(angles, axis=0)  # absolute angle of each phalanx: the FCI's rows
    lengths = np.asarray(PHALANX_ENDS)[:, None]
    dy = np.cumsum(-lengths * np.sin(phi), axis=0)
    dz = np.cumsum(lengths * np.cos(phi), axis=0)
    knuckle = np.array([KNUCKLE_Z[f] for f in LONG_FINGERS])
    return np.stack([dy.T, dz.T + knuckle[:, None]], axis=-1)


@dataclass(frozen=True)
class FingerPointsDescriptor:
    """Phalanx ends (J2, J1, tip; y and z in m) of each long finger: where it wrapped
    (``profile``: as the four fingers' mean and each finger's deviation from it)."""

    profile: bool = False
    name: ClassVar[str] = "finger-points"

    def __post_init__(self) -> None:
        if not isinstance(self.profile, bool | np.bool_):
            raise UsageError(f"{self.name} profile must be true or false, got {self.profile!r}")

    @property
    def params(self) -> dict:
        return asdict(self)

    def feature_names(self) -> list[str]:
        each = [f"{p}_{axis}" for p in POINTS for axis in "yz"]
        if self.profile:
            deviations = [f"{f}_{e}_dev" for f in LONG_FINGERS for e in each]
            return [f"mean_{e}" for e in each] + deviations
        return [f"{f}_{e}" for f in LONG_FINGERS for e in each]

    def _angles(self, record) -> np.ndarray:
        return record.fci_angles()

    def transform(self, records) -> np.ndarray:
        items = check_records(records)
        points = np.empty((len(items), len(LONG_FINGERS), len(POINTS) * 2))
        for row, record in enumerate(items):
            points[row] = finger_points(self._angles(record)).reshape(len(LONG_FINGERS), -1)
        flat = len(LONG_FINGERS) * len(POINTS) * 2
        if not self.profile:
            return points.reshape(len(items), flat)
        mean = points.mean(axis=1) if len(items) else points[:, 0]
        return np.hstack([mean, (points - mean[:, None, :]).reshape(len(items), flat)])


@dataclass(frozen=True)
class CoupledFingerPointsDescriptor(FingerPointsDescriptor):
    """:class:`FingerPointsDescriptor` of the record with J0 split evenly (J3 and J0 only)."""

    name: ClassVar[str] = "coupled-finger-points"

    def _angles(self, record) -> np.ndarray:
        return coupled_record(record).fci_angles()
