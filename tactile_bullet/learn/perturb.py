"""A seeded sensor model: what a real hand's encoders and torque sensors add to a clean grasp.

A simulated record is perfect proprioception. A real Shadow hand reads its joints through Hall
sensors that drift and are calibrated by hand, so every joint carries a fixed offset of a few
degrees (the calibration bias) plus sample-to-sample jitter, and its torque readings are noisy.
:func:`perturb` applies that model to a record *before* any descriptor sees it:

- ``bias`` (rad): each joint gets one offset drawn uniformly in [-bias, +bias], the same for
  every sample of the grasp (a calibration error does not change within a grasp);
- ``sigma`` (rad): independent Gaussian noise on every angle sample, and on the final angles;
- ``effort_sigma`` (N m): independent Gaussian noise on every effort sample.

The final angles are the last sample's angles: the record's ``final_angles`` get the same bias
and their own draw of noise (the final state is one more reading of the encoders), so
descriptors that read the final configuration and those that read the series see one hand.
Contacts are reported in the palm frame, which a real hand computes from the tactile sensor
on the link through the forward kinematics of the *measured* angles: each contact of a long
finger's proximal, middle or distal link keeps its place and normal on the link, and the link
is placed by the measured final angles instead of the true ones (the finger's planar chain of
docs/hand.md: J4 about the palm normal at the knuckle, J3, J2, J1 about palm x at the knuckle
and the phalanx ends; LF J5 taken as 0, as :mod:`.finger_points` does). A 3 deg bias at J3
moves a fingertip contact ~5 mm. Thumb contacts (its joint axes are not parallel) and knuckle
contacts are left as simulated. (Until the contact rules read the points, only the normals
were turned and the points stayed where they were simulated: an inconsistent hand.)
Joints the simulator holds fixed (the welded wrist, reported at 0) are perturbed like the
others: a real hand reports them through the same sensors.

A pure function: the input record is untouched and the same (record, model, seed) always gives
the same output, so a benchmark is reproducible and the model can be applied unchanged to
recordings imported from a real hand (to ask how a model trained on them degrades further).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import UsageError
from ..records import GraspRecord


@dataclass(frozen=True)
class SensorModel:
    """Joint-angle noise ``sigma`` (rad), per-joint calibration bias bound ``bias`` (rad) and
    effort noise ``effort_sigma`` (N m); all zero is a perfect sensor."""

    sigma: float = 0.0
    bias: float = 0.0
    effort_sigma: float = 0.0

    def __post_init__(self) -> None:
        for name in ("sigma", "bias", "effort_sigma"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float | np.floating):
                raise UsageError(f"sensor {name} must be a number, got {value!r}")
            if not (math.isfinite(value) and value >= 0.0):
                raise UsageError(f"sensor {name} must be finite and >= 0, got {value!r}")
            object.__setattr__(self, name, float(value))

    @classmethod
    def degrees(cls, sigma: float = 0.0, bias: float = 0.0, effort_sigma: float = 0.0):
        """The model with angles given in degrees (the units people quote encoders in)."""
        return cls(math.radians(sigma), math.radians(bias), effort_sigma)

    @property
    def is_clean(self) -> bool:
        return self.sigma == 0.0 and self.bias == 0.0 and self.effort_sigma == 0.0

    def label(self) -> str:
        """Short human name, degrees: ``sigma 1 deg, bias 3 deg, effort 0.02 N m``."""
        if self.is_clean:
            return "clean"
        parts = []
        if self.sigma:
            parts.append(f"sigma {math.degrees(self.sigma):g} deg")
        if self.bias:
            parts.append(f"bias {math.degrees(self.bias):g} deg")
        if self.effort_sigma:
            parts.append(f"effort {self.effort_sigma:g} N m")
        return ", ".join(parts)


def perturb(
    record: GraspRecord, model: SensorModel, seed: int | np.random.Generator
) -> GraspRecord:
    """A copy of ``record`` as the sensors of ``model`` would have read it (see module doc).

    ``seed`` (an int or a Generator) fixes the draws: the bias per joint, then the series noise,
    the final-angle noise and the effort noise, in that order."""
    if model.is_clean:
        return record
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    n = len(record.joint_names)
    offset = rng.uniform(-model.bias, model.bias, n) if model.bias else np.zeros(n)
    angles = np.asarray(record.angles, dtype=float)
    final = np.asarray(record.final_angles, dtype=float)
    efforts = np.asarray(record.efforts, dtype=float)
    noise_series = rng.normal(0.0, model.sigma, angles.shape) if model.sigma else 0.0
    noise_final = rng.normal(0.0, model.sigma, final.shape) if model.sigma else 0.0
    noisy_efforts = (
        efforts + rng.normal(0.0, model.effort_sigma, efforts.shape)
        if model.effort_sigma
        else efforts
    )
    new_final = final + offset + noise_final
    points, normals = moved_contacts(record, new_final - final)
    return replace(
        record,
        angles=angles + offset + noise_series if angles.size else angles,
        final_angles=new_final,
        efforts=noisy_efforts,
        contact_position=points,
        contact_normal=normals,
        flags=tuple(record.flags) + ("perturbed",),
    )


_DEPTH = {"proximal": 1, "middle": 2, "distal": 3, "tip": 3}
"""Phalanges between the knuckle and a long finger's link (its tip frame rides the distal)."""

_J4_AXIS_Y = {"ff": -1.0, "mf": -1.0, "rf": 1.0, "lf": 1.0}
"""The y of each long finger's J4 axis (docs/hand.md): FF and MF spread about -y, RF and LF
about +y."""


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(b: float) -> np.ndarray:
    c, s = math.cos(b), math.sin(b)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def link_pose(finger: str, angles: dict[str, float], depth: int) -> tuple[np.ndarray, np.ndarray]:
    """(rotation, origin) in the palm frame of the ``depth``-th phalanx of long ``finger`` at
    joint ``angles`` (name -> rad): J4 turns the finger about its axis (+-y) at the knuckle,
    J3, J2 and J1 flex it about +x (toward -y) at the knuckle and the phalanx ends."""
    from ..hand import FINGER_X, KNUCKLE_Z
    from .finger_points import PHALANX_ENDS

    up = finger.upper()
    rot = _ry(_J4_AXIS_Y[finger] * angles.get(f"{up}J4", 0.0)) @ _rx(angles.get(f"{up}J3", 0.0))
    origin = np.array([FINGER_X[finger], 0.0, KNUCKLE_Z[finger]])
    for k, joint in zip(range(1, depth), ("J2", "J1"), strict=False):
        origin = origin + rot @ np.array([0.0, 0.0, PHALANX_ENDS[k - 1]])
        rot = rot @ _rx(angles.get(f"{up}{joint}", 0.0))
    return rot, origin


def moved_contacts(record: GraspRecord, errors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Contact positions and normals as forward kinematics with final-angle ``errors`` (rad,
    per joint in ``record.joint_names`` order) would report them (module doc)."""
    from ..hand import LONG_FINGERS

    points = np.array(record.contact_position, dtype=float).reshape(-1, 3)
    normals = np.array(record.contact_normal, dtype=float).reshape(-1, 3)
    if not len(points):
        return points, normals
    names = list(record.joint_names)
    true = dict(zip(names, np.asarray(record.final_angles, dtype=float).tolist(), strict=True))
    read = dict(zip(names, (np.asarray(record.final_angles, dtype=float)
                            + np.asarray(errors, dtype=float)).tolist(), strict=True))  # fmt: skip
    poses: dict[tuple[str, int], tuple] = {}
    for row, link in enumerate(np.asarray(record.contact_link).astype(str)):
        finger = link[:2]
        depth = _DEPTH.get(link[2:])
        if finger not in LONG_FINGERS or depth is None:
            continue
        if (finger, depth) not in poses:
            (r0, t0), (r1, t1) = (link_pose(finger, a, depth) for a in (true, read))
            poses[finger, depth] = (r1 @ r0.T, t1 - r1 @ r0.T @ t0)
        turn, shift = poses[finger, depth]
        points[row] = turn @ points[row] + shift
        normals[row] = turn @ normals[row]
    return points, normals


def perturb_all(records, model: SensorModel, seed: int = 0) -> list[GraspRecord]:
    """Each record perturbed with its own stream (record i: ``SeedSequence([seed, i])``), so a
    record's perturbation does not depend on which others are in the list before it."""
    return [
        perturb(r, model, np.random.default_rng(np.random.SeedSequence([int(seed), i])))
        for i, r in enumerate(records)
    ]
