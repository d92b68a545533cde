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
Contact normals are reported in the palm frame, which a real hand computes from the fingertip
sensor through the forward kinematics of the *measured* angles: each long finger's contact
normals are turned by that finger's final-angle errors (about the flexion axis, palm x, by the
sum of the errors of the flexion joints between the palm and the touching link; about the palm
normal by the J4 error). Thumb contacts and contact positions are left as simulated (the
thumb's joint axes are not parallel; no built-in descriptor reads positions).
Joints the simulator holds fixed (the welded wrist, reported at 0) are perturbed like the
others: a real hand reports them through the same sensors.

A pure function: the input record is untouched and the same (record, model, seed) always gives
the same output, so a benchmark is reproducible and the model can be applied unchanged to
recordings imported from a real hand (to ask how a model trained on them degrades further).
"""

from __future__ import annotations

import functools
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
    return replace(
        record,
        angles=angles + offset + noise_series if angles.size else angles,
        final_angles=new_final,
        efforts=noisy_efforts,
        contact_normal=turned_normals(record, new_final - final),
        flags=tuple(record.flags) + ("perturbed",),
    )


@functools.cache
def _link_joints() -> dict[str, tuple[tuple[str, ...], str]]:
    """Long-finger link -> (flexion joints between the palm and it, abduction joint)."""
    from ..hand import FINGER_LINKS, LONG_FINGERS

    out = {}
    for f in LONG_FINGERS:
        up = f.upper()
        chain = {"proximal": (3,), "middle": (3, 2), "distal": (3, 2, 1), "tip": (3, 2, 1)}
        for link in FINGER_LINKS[f]:
            for part, joints in chain.items():
                if link == f"{f}{part}":
                    out[link] = (tuple(f"{up}J{j}" for j in joints), f"{up}J4")
    return out


def turned_normals(record: GraspRecord, errors: np.ndarray) -> np.ndarray:
    """Contact normals as forward kinematics with final-angle ``errors`` (rad, per joint in
    ``record.joint_names`` order) would report them (module doc)."""
    normals = np.array(record.contact_normal, dtype=float).reshape(-1, 3)
    if not len(normals):
        return normals
    table = _link_joints()
    index = {n: i for i, n in enumerate(record.joint_names)}
    for row, link in enumerate(np.asarray(record.contact_link).astype(str)):
        if link not in table:
            continue
        flexion, abduction = table[link]
        a = float(sum(errors[index[j]] for j in flexion if j in index))
        b = -float(errors[index[abduction]]) if abduction in index else 0.0
        rot_x = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
        rot_y = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
        normals[row] = rot_y @ rot_x @ normals[row]
    return normals


def perturb_all(records, model: SensorModel, seed: int = 0) -> list[GraspRecord]:
    """Each record perturbed with its own stream (record i: ``SeedSequence([seed, i])``), so a
    record's perturbation does not depend on which others are in the list before it."""
    return [
        perturb(r, model, np.random.default_rng(np.random.SeedSequence([int(seed), i])))
        for i, r in enumerate(records)
    ]
