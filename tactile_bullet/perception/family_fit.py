"""What the shape fit reads and returns: the measured features of a grasp (J3 and the coupled
J0 per long finger) and the fit of each family (:class:`FamilyFit`) and of all
(:class:`ShapeFit`). Plain data; the search is :mod:`.shape_fit`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UsageError


def measured_features(angles) -> np.ndarray:
    """(2, 4) J3 and J0 = J2 + J1 per long finger from final angles (3, 4): rows J3, J2, J1,
    columns ff, mf, rf, lf (rad), as ``GraspRecord.fci_angles`` gives them."""
    try:
        arr = np.asarray(angles, dtype=float)
    except (TypeError, ValueError):
        raise UsageError("joint angles must be numbers (3 x 4: J3, J2, J1 x ff..lf)") from None
    if arr.shape != (3, 4):
        raise UsageError(
            f"joint angles must be a 3 x 4 array (rows J3, J2, J1; columns ff, mf, rf, lf), "
            f"got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise UsageError("joint angles contain NaN or infinity")
    return np.stack([arr[0], arr[1] + arr[2]])


@dataclass(frozen=True)
class FamilyFit:
    """Best fit of one shape family: sizes (m), offset (m: along O-O', along the fingers),
    ``rotation_deg`` about the palm normal, ``residual`` the RMS angle error (rad) over the
    eight fitted angles, ``score`` the penalised robust cost the identification compares,
    ``predicted`` (2, 4) J3, J0."""

    shape: str
    params: dict[str, float]
    offset: tuple[float, float]
    residual: float
    score: float
    predicted: np.ndarray
    rotation_deg: float = 0.0

    def summary(self) -> dict:
        return {
            "params": self.params,
            "offset_m": list(self.offset),
            "rotation_deg": self.rotation_deg,
            "residual_rad": self.residual,
            "score": self.score,
        }


@dataclass(frozen=True)
class ShapeFit:
    """Outcome of :func:`fit_shape`: the best family and every family's fit."""

    shape: str
    fits: dict[str, FamilyFit]

    @property
    def best(self) -> FamilyFit:
        return self.fits[self.shape]

    @property
    def params(self) -> dict[str, float]:
        """The fitted sizes of the identified shape (m)."""
        return self.best.params

    @property
    def residual(self) -> float:
        return self.best.residual

    def summary(self) -> dict:
        """The ``shape_fit`` block of ``grasp --json``."""
        return {
            "shape": self.shape,
            "params": self.best.params,
            "offset_m": list(self.best.offset),
            "rotation_deg": self.best.rotation_deg,
            "residual": self.best.residual,
            "scores": {name: fit.score for name, fit in self.fits.items()},
        }
