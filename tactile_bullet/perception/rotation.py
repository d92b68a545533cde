"""Object rotation in the hand from the signature's slope (thesis Figs 2.25-2.26).

The enhancement removes each line's end-point slope alpha; alpha itself says how the object is
turned about the palm normal, because a tilted axis meets each finger at a different height.
The relation is calibrated on simulated grasps of known rotation (``tools/rotation_calibration
.py``): a least-squares line alpha = slope * rotation + intercept, inverted to estimate the
rotation. The fit is stored as package data (``data/rotation_calibration.json``).

alpha at zero rotation is not zero and depends on the shape (the hand's own knuckle heights
tilt every signature, by an amount that depends on the object), so the calibration keeps one
line per calibrated shape besides the pooled one; the estimate uses the shape's own line when
the shape is given (e.g. the identified pattern) and the pooled line otherwise.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from functools import cache
from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import UsageError

LINES = ("lower", "upper", "mean")
"""Which alpha a calibration uses: one line's, or the mean of both."""


@dataclass(frozen=True)
class RotationCalibration:
    """A linear fit of measured alpha (deg) against actual rotation (deg), and its quality."""

    slope: float
    intercept: float
    r2: float
    mae_deg: float
    """Mean absolute error (deg) of the inverted estimate on the calibration grasps."""
    line: str = "mean"
    samples: int = 0
    range_deg: tuple[float, float] = (0.0, 25.0)
    shapes: tuple[str, ...] = ()
    per_shape: Mapping[str, Mapping[str, float]] = field(default_factory=dict)

    def estimate(self, alpha_deg: float, shape: str | None = None) -> float | None:
        """Rotation (deg) that would produce ``alpha_deg``: with ``shape``'s own line, None
        for a shape the calibration has no line for (a cone's signature is sloped by its
        shape, not by a rotation; the pooled line's error is ~28 deg), the pooled line when
        no shape is given."""
        if shape is None:
            return (float(alpha_deg) - self.intercept) / self.slope
        own = self.per_shape.get(shape)
        if own and np.isfinite(own["slope"]) and own["slope"] != 0:
            return (float(alpha_deg) - own["intercept"]) / own["slope"]
        return None


def alpha_of(signature, line: str = "mean") -> float:
    """The alpha (deg) a calibration of ``line`` reads from a Signature."""
    if line == "lower":
        return float(signature.alpha_lower)
    if line == "upper":
        return float(signature.alpha_upper)
    if line == "mean":
        return float(signature.alpha_deg)
    raise UsageError(f"line must be one of {', '.join(LINES)}, got {line!r}")


def _line_fit(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    slope, intercept = np.polyfit(x, y, 1)
    resid = y - (slope * x + intercept)
    total = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid**2)) / total if total > 0 else 0.0
    return float(slope), float(intercept), r2


def fit_calibration(
    actual_deg: Sequence[float],
    alpha_deg: Sequence[float],
    line: str = "mean",
    shapes: Sequence[str] | None = None,
) -> RotationCalibration:
    """Least-squares line through (actual rotation, measured alpha) pairs.

    ``shapes`` (one name per sample) adds a fit per shape to ``per_shape`` for the report;
    the pooled fit is what :func:`estimate_rotation_deg` uses, since the shape is not known
    for sure when the rotation is estimated.
    """
    x = np.asarray(actual_deg, dtype=float)
    y = np.asarray(alpha_deg, dtype=float)
    if x.shape != y.shape or x.ndim != 1 or x.size < 3:
        raise UsageError("calibration needs matching 1-D arrays of at least 3 samples")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise UsageError("calibration samples contain NaN or infinity")
    if np.ptp(x) == 0:
        raise UsageError("calibration needs at least two different rotations")
    slope, intercept, r2 = _line_fit(x, y)
    if slope == 0:
        raise UsageError("alpha does not change with the rotation: nothing to calibrate")
    mae = float(np.mean(np.abs((y - intercept) / slope - x)))
    per_shape: dict[str, dict[str, float]] = {}
    names = tuple(shapes) if shapes is not None else ()
    if names:
        if len(names) != x.size:
            raise UsageError("shapes must name the shape of every calibration sample")
        for name in sorted(set(names)):
            m = np.array([n == name for n in names])
            if m.sum() >= 3 and np.ptp(x[m]) > 0:
                s, b, r = _line_fit(x[m], y[m])
                own = float(np.mean(np.abs((y[m] - b) / s - x[m]))) if s else float("nan")
                pooled = float(np.mean(np.abs((y[m] - intercept) / slope - x[m])))
                per_shape[name] = {
                    "slope": s,
                    "intercept": b,
                    "r2": r,
                    "mae_deg_own_fit": own,
                    "mae_deg_pooled_fit": pooled,
                }
    return RotationCalibration(
        slope=slope,
        intercept=intercept,
        r2=r2,
        mae_deg=mae,
        line=line,
        samples=int(x.size),
        range_deg=(float(x.min()), float(x.max())),
        shapes=tuple(sorted(set(names))),
        per_shape=per_shape,
    )


def save_calibration(cal: RotationCalibration, path: str | Path) -> Path:
    """Write a calibration as JSON."""
    path = Path(path)
    doc = asdict(cal)
    doc["range_deg"] = list(cal.range_deg)
    doc["shapes"] = list(cal.shapes)
    path.write_text(json.dumps(doc, indent=2, sort_keys=True) + "\n")
    return path


def calibration_from_dict(doc: Mapping) -> RotationCalibration:
    """Rebuild a calibration from its JSON form, checking it can be inverted."""
    try:
        cal = RotationCalibration(
            slope=float(doc["slope"]),
            intercept=float(doc["intercept"]),
            r2=float(doc["r2"]),
            mae_deg=float(doc["mae_deg"]),
            line=str(doc.get("line", "mean")),
            samples=int(doc.get("samples", 0)),
            range_deg=tuple(float(v) for v in doc.get("range_deg", (0.0, 25.0))),
            shapes=tuple(doc.get("shapes", ())),
            per_shape=dict(doc.get("per_shape", {})),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise UsageError(f"not a rotation calibration ({type(exc).__name__}: {exc})") from None
    if cal.line not in LINES or not np.isfinite(cal.slope) or cal.slope == 0:
        raise UsageError("rotation calibration has an unusable line or slope")
    return cal


@cache
def load_calibration() -> RotationCalibration | None:
    """The packaged calibration, or None when it has not been generated."""
    try:
        text = resources.files("tactile_bullet").joinpath("data/rotation_calibration.json")
        doc = json.loads(text.read_text())
    except (FileNotFoundError, OSError):
        return None
    return calibration_from_dict(doc)


def estimate_rotation_deg(
    alpha_deg: float,
    calibration: RotationCalibration | None = None,
    shape: str | None = None,
) -> float | None:
    """Object rotation (deg) about the palm normal from a measured alpha (deg), with the
    packaged calibration unless one is given (``shape``'s own line where it has one); None
    when no calibration exists."""
    value = float(alpha_deg)
    if not np.isfinite(value):
        raise UsageError(f"alpha must be finite, got {alpha_deg!r}")
    cal = load_calibration() if calibration is None else calibration
    return None if cal is None else cal.estimate(value, shape)
