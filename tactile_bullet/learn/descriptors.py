"""Built-in plugin: descriptors, the maps from grasp records to feature vectors.

A descriptor is any object with ``name``, ``params`` (a dict), ``transform(records) -> (n, d)
float array`` and ``feature_names() -> list[str]`` (d names). Plugins register factories
(``factory(**params)`` -> descriptor) through the ``register_descriptors`` hook; combinations
such as ``"signature+contact-normals"`` are built by ``plugins.get_descriptor``.

Built-in ones (zeroth-order data: proprioception; first-order: contact normals, thesis ch. 4):

- ``signature``: the enhanced proprioceptive signature (thesis 2.3, ``floor`` being the
  enhancement's flatness floor), both lines resampled to ``points`` each, then each line's
  bulge (the size-free "integral of the signature" that splits hyperboloid from cylinder);
  with ``alpha=True`` each line's slope angle alpha (deg, which carries the object's
  rotation), and with ``level=True`` the mean raw upper line (grey
  levels: how far the fingers closed, so the object's size), which lets ``dtw-template``
  compare with the theoretical pattern at the size the hand felt. Both are off by default so
  the descriptor stays free of rotation and size, as the thesis' signature is. With
  ``correction="position"`` or ``"dynamic"`` the signature is built from the fingers that
  detector (``perception/temporal.py``, thesis ch. 3) finds in contact only: SVM_pos and SVM_dyn.
- ``raw-joints``: the final angles of the four long fingers (J4..J1, LF J5 too), and the
  thumb's J5..J1 with ``include_thumb=True`` (off by default: the thumb is held at a fixed
  opposed pose, so its angles carry little but noise).
- ``contact-normals``: per fingertip the object's unit outward normal in the palm frame,
  averaged over the contacts on the distal and tip links weighted by normal force, and a
  contact indicator. A finger without such a contact gives the normal (0, 0, 0) and
  indicator 0, so the classifier sees "no contact" as a value of its own rather than NaN.
- ``time-series``: the whole joint-angle and effort series of the grasp, resampled to a fixed
  length (``learn/time_series.py``; the ``tcn`` classifier's input).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import ClassVar

import numpy as np

from ..errors import UsageError
from ..hand import FINGER_LINKS, FINGERS, LONG_FINGERS
from ..perception.signature import resample_line

SIGNATURE_LINE_POINTS = 10
"""Default samples per signature line. The 200-column line is a cubic interpolation of four
fingers, so it has about four degrees of freedom: 10 samples keep its shape, and unlike 50 they
do not outweigh the two bulge columns in an RBF kernel's distance. Signature + svm, mean over
six splits of the demo protocol (``python benchmarks/bench_accuracy.py --seeds 0,1,2,3,4,5
[--descriptor-param points=50]``): 95.8% at 10 points, 93.0% at 50. The other classifiers lean
the other way on the same splits (``... --classifier knn --descriptor-param points=50``):
knn 86.2% vs 82.2%, som 82.8% vs 77.7%, so give them ``--descriptor-param points=50``. The
neural forest, which trains in whitened coordinates, prefers 10 (seeds 0-3: 95.8% vs 91.0%)."""

SIGNATURE_FLOOR = 0.05
"""Default flatness floor of the enhancement (``signature.enhance``): a line whose deviations
stay under 5% of its mean level is not stretched to [-1, 1]. A cylinder's measured lines wobble
by a few percent (the J1/J2 tendon split differs finger to finger), and the thesis' full
normalisation turns that wobble into a hyperboloid-like curve. Same six splits
(``... --descriptor-param floor=0.02``): 95.8% at 0.05, 93.0% at 0.02. The training-free
identifier keeps ``signature.FLAT_FLOOR`` (0.02): with 0.05 there, ``tools/invariance.py``
identified 57% of its grid instead of 60%.
"""


def check_records(records) -> Sequence:
    """The records as a sequence, or a UsageError saying what was passed instead."""
    if hasattr(records, "final_angles"):
        raise UsageError("a descriptor takes a sequence of grasp records, not a single record")
    try:
        items = list(records)
    except TypeError:
        raise UsageError(
            f"a descriptor takes a sequence of grasp records, got {type(records).__name__}"
        ) from None
    for item in items:
        if not hasattr(item, "final_angles") or not hasattr(item, "fci_angles"):
            raise UsageError(f"not a grasp record: {type(item).__name__}")
    return items


def signature_layout(points: int, alpha: bool = False, level: bool = False) -> list[str]:
    """Feature names of the signature descriptor, in column order."""
    names = [f"lower_{i:03d}" for i in range(points)] + [f"upper_{i:03d}" for i in range(points)]
    names += ["bulge_lower", "bulge_upper"]
    if alpha:
        names += ["alpha_lower_deg", "alpha_upper_deg"]
    if level:
        names += ["level_upper"]
    return names


@dataclass(frozen=True)
class SignatureDescriptor:
    """The enhanced signature: lower line, upper line (``points`` each), bulges[, alphas]
    [, level]."""

    points: int = SIGNATURE_LINE_POINTS
    alpha: bool = False
    level: bool = False
    floor: float = SIGNATURE_FLOOR
    correction: str = "none"
    """Drop the fingers a non-contact detector flags before the signature is built (thesis
    Fig 3.11): "none", "position" or "dynamic" (``perception/temporal.py``; needs the time
    series)."""
    name: ClassVar[str] = "signature"

    def __post_init__(self) -> None:
        if isinstance(self.points, bool) or not isinstance(self.points, int | np.integer):
            raise UsageError(f"signature points must be an integer, got {self.points!r}")
        if not 3 <= self.points <= 200:
            raise UsageError(f"signature points must be from 3 to 200, got {self.points}")
        for flag in ("alpha", "level"):
            if not isinstance(getattr(self, flag), bool | np.bool_):
                raise UsageError(
                    f"signature {flag} must be true or false, got {getattr(self, flag)!r}"
                )
        floor = self.floor
        if (
            isinstance(floor, bool)
            or not isinstance(floor, int | float | np.floating | np.integer)
            or not 0.0 <= float(floor) <= 1.0
        ):
            raise UsageError(f"signature floor must be a number from 0 to 1, got {floor!r}")
        from ..perception.temporal import CORRECTIONS

        if self.correction is None:  # `--descriptor-param correction=none` parses to None
            object.__setattr__(self, "correction", "none")
        if self.correction not in CORRECTIONS:
            raise UsageError(
                f"signature correction must be one of {', '.join(CORRECTIONS)}, "
                f"got {self.correction!r}"
            )

    @property
    def params(self) -> dict:
        return asdict(self)

    def feature_names(self) -> list[str]:
        return signature_layout(self.points, bool(self.alpha), bool(self.level))

    def transform(self, records) -> np.ndarray:
        from ..perception.signature import signature_of
        from ..perception.temporal import signature_corrected

        items = check_records(records)
        out = np.empty((len(items), len(self.feature_names())))
        for row, record in enumerate(items):
            if self.correction == "none":
                sig = signature_of(record, floor=float(self.floor))
            else:
                sig = signature_corrected(record, self.correction, floor=float(self.floor))
            values = [
                resample_line(sig.lower, self.points),
                resample_line(sig.upper, self.points),
                [sig.bulge_lower, sig.bulge_upper],
            ]
            if self.alpha:
                values.append([sig.alpha_lower, sig.alpha_upper])
            if self.level:
                values.append([float(np.mean(sig.raw_upper))])
            out[row] = np.concatenate(values)
        return out


def raw_joint_names(include_thumb: bool) -> list[str]:
    """Joints of the raw-joints descriptor: long fingers J4..J1 (LF J5..J1), thumb J5..J1."""
    names = []
    for finger in LONG_FINGERS:
        first = 5 if finger == "lf" else 4
        names += [f"{finger.upper()}J{j}" for j in range(first, 0, -1)]
    if include_thumb:
        names += [f"THJ{j}" for j in range(5, 0, -1)]
    return names


@dataclass(frozen=True)
class RawJointsDescriptor:
    """Final joint angles (rad) of the fingers, in ``raw_joint_names`` order."""

    include_thumb: bool = False
    name: ClassVar[str] = "raw-joints"

    def __post_init__(self) -> None:
        if not isinstance(self.include_thumb, bool | np.bool_):
            raise UsageError(
                f"raw-joints include_thumb must be true or false, got {self.include_thumb!r}"
            )

    @property
    def params(self) -> dict:
        return asdict(self)

    def feature_names(self) -> list[str]:
        return raw_joint_names(bool(self.include_thumb))

    def transform(self, records) -> np.ndarray:
        items = check_records(records)
        names = self.feature_names()
        out = np.empty((len(items), len(names)))
        for row, record in enumerate(items):
            out[row] = [record.final(n) for n in names]
        return out


FINGERTIP_LINKS: dict[str, tuple[str, ...]] = {
    f: tuple(link for link in FINGER_LINKS[f] if link.endswith(("distal", "tip"))) for f in FINGERS
}
"""The links whose contacts count as a fingertip contact (distal phalanx and tip)."""


def fingertip_normal(record, finger: str) -> tuple[np.ndarray, bool]:
    """Force-weighted mean outward normal of one finger's tip contacts, and whether any.

    Weights are the normal forces; if they sum to zero the contacts count equally. A mean that
    cancels out (opposite normals) or no tip contact gives ((0, 0, 0), False).
    """
    mask = np.isin(np.asarray(record.contact_link).astype(str), FINGERTIP_LINKS[finger])
    if not mask.any():
        return np.zeros(3), False
    normals = np.asarray(record.contact_normal, dtype=float).reshape(-1, 3)[mask]
    forces = np.clip(np.asarray(record.contact_force, dtype=float)[mask], 0.0, None)
    weights = forces if forces.sum() > 0 else np.ones(len(normals))
    mean = weights @ normals
    norm = float(np.linalg.norm(mean))
    if not np.isfinite(norm) or norm < 1e-9:
        return np.zeros(3), False
    return mean / norm, True


@dataclass(frozen=True)
class ContactNormalsDescriptor:
    """Per fingertip: unit outward normal (palm frame) and a 0/1 contact indicator."""

    include_thumb: bool = True
    name: ClassVar[str] = "contact-normals"
    reads_contacts: ClassVar[bool] = True
    """Its features come from the grasp's contacts, which a real hand's recording lacks."""

    def __post_init__(self) -> None:
        if not isinstance(self.include_thumb, bool | np.bool_):
            raise UsageError(
                f"contact-normals include_thumb must be true or false, got {self.include_thumb!r}"
            )

    @property
    def params(self) -> dict:
        return asdict(self)

    def fingers(self) -> tuple[str, ...]:
        return FINGERS if self.include_thumb else LONG_FINGERS

    def feature_names(self) -> list[str]:
        return [f"{f}_{c}" for f in self.fingers() for c in ("nx", "ny", "nz", "contact")]

    def transform(self, records) -> np.ndarray:
        items = check_records(records)
        fingers = self.fingers()
        out = np.zeros((len(items), 4 * len(fingers)))
        for row, record in enumerate(items):
            for col, finger in enumerate(fingers):
                normal, touched = fingertip_normal(record, finger)
                out[row, 4 * col : 4 * col + 3] = normal
                out[row, 4 * col + 3] = float(touched)
        return out


@dataclass(frozen=True)
class ConcatDescriptor:
    """Several descriptors side by side (``plugins.get_descriptor("a+b")``)."""

    parts: tuple

    @property
    def name(self) -> str:
        return "+".join(p.name for p in self.parts)

    @property
    def reads_contacts(self) -> bool:
        return any(getattr(p, "reads_contacts", False) for p in self.parts)

    @property
    def params(self) -> dict:
        return {f"{p.name}.{k}": v for p in self.parts for k, v in p.params.items()}

    def feature_names(self) -> list[str]:
        return [f"{p.name}:{n}" for p in self.parts for n in p.feature_names()]

    def transform(self, records) -> np.ndarray:
        items = check_records(records)
        blocks = [np.asarray(p.transform(items), dtype=float) for p in self.parts]
        for part, block in zip(self.parts, blocks, strict=True):
            if block.shape != (len(items), len(part.feature_names())):
                raise ValueError(
                    f"descriptor {part.name!r} returned shape {block.shape}, expected "
                    f"({len(items)}, {len(part.feature_names())})"
                )
        return np.hstack(blocks) if blocks else np.empty((len(items), 0))
