"""What a saved ``shape-fit`` model loads as (:class:`ShapeFitVote`, the registry's
``fitted_form`` for ``shape-fit``), and the pieces the estimator shares with it.

The shape fit learns nothing from its training grasps: a model of it is its classes, its
temperature and, optionally, a hand's coefficients. Answering with it needs the fit and numpy,
not scikit-learn, whose import (~0.9 s) was half of an ``evaluate`` of a shape-fit model on the
tour's 39 grasps.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..hand import LONG_FINGERS
from .descriptors import raw_joint_names
from .rows import feature_rows


def fci_columns(n_features: int) -> np.ndarray:
    """(3, 4) column indices of J3, J2, J1 per long finger in the raw-joints layout."""
    for thumb in (False, True):
        names = raw_joint_names(thumb)
        if len(names) == n_features:
            return np.array(
                [[names.index(f"{f.upper()}J{j}") for f in LONG_FINGERS] for j in (3, 2, 1)]
            )
    raise ValueError(
        f"shape-fit expects the raw-joints descriptor's {len(raw_joint_names(False))} or "
        f"{len(raw_joint_names(True))} columns, got {n_features}"
    )


def checked_calibration(doc):
    """The ``calibration`` parameter as coefficients (None: those in force when fitting), every
    value checked as a hand calibration file's are (ValueError, one line, otherwise)."""
    if doc is None:
        return None
    from dataclasses import replace

    from ..errors import UsageError
    from ..realhand.hand_calibration import checked_coefficients

    if not isinstance(doc, dict):
        raise ValueError("shape-fit calibration must be a table of coefficients or None")
    doc = dict(doc)
    angles = doc.pop("angles", "raw")
    if angles not in ("raw", "zeroed"):
        raise ValueError(f"shape-fit calibration angles must be raw or zeroed, not {angles!r}")
    try:
        return replace(checked_coefficients(doc, "shape-fit calibration"), angles=angles)
    except UsageError as exc:
        raise ValueError(str(exc)) from None


def fit_scores(X: np.ndarray, classes, calibration) -> np.ndarray:
    """(n, n_classes) penalised fit scores of raw-joints rows ``X`` (lower is better), every
    grasp's fit kept (``predict`` then ``predict_proba`` fit once) and run on every core
    (:func:`~tactile_bullet.perception.fit_batch.fit_many`)."""
    from ..perception.fit_batch import fit_many

    cols = fci_columns(X.shape[1])
    names = [str(c) for c in classes]
    fits = fit_many([x[cols] for x in X], names, calibration)
    return np.array([[fit.fits[n].score for n in names] for fit in fits]).reshape(
        len(X), len(names)
    )


def probabilities(scores: np.ndarray, temperature: float) -> np.ndarray:
    """p ~ exp(-score / temperature), each row summing to 1."""
    weights = np.exp(-(scores - scores.min(axis=1, keepdims=True)) / float(temperature))
    return weights / weights.sum(axis=1, keepdims=True)


def checked_state(state: dict, arrays: dict[str, np.ndarray]) -> tuple[float, Any, np.ndarray, int]:
    """(temperature, calibration parameter, classes, feature count) of a saved state, every
    value checked (ValueError, one line, where one is damaged)."""
    from ..perception import shape_fit

    temperature = state["params"]["temperature"]
    if isinstance(temperature, bool) or not isinstance(temperature, int | float) \
            or not (np.isfinite(temperature) and temperature > 0):  # fmt: skip
        raise ValueError(f"temperature {temperature!r} is not a positive number")
    n = state["n_features_in"]
    if not isinstance(n, int) or isinstance(n, bool):
        raise ValueError(f"n_features_in {n!r} is not a count")
    fci_columns(n)  # a layout the fit reads, else ValueError
    classes = np.asarray(arrays["classes"])
    if classes.ndim != 1 or len(classes) < 1 or classes.dtype.kind != "U":
        raise ValueError("classes must be a list of shape names")
    unknown = sorted(set(classes.tolist()) - set(shape_fit.fitted_shapes()))
    if unknown:
        raise ValueError(f"class {unknown[0]!r} is not a shape the fit models")
    return float(temperature), state["params"]["calibration"], classes, n


def state_of(temperature, calibration, classes, n_features: int) -> tuple[dict, dict]:
    """The saved state of a shape-fit model (:func:`checked_state` reads it back)."""
    state = {"params": {"temperature": float(temperature), "calibration": calibration},
             "n_features_in": int(n_features)}  # fmt: skip
    return state, {"classes": np.asarray(classes).astype(str)}


class ShapeFitVote:
    """A shape-fit model read from a file: ``predict`` and ``predict_proba`` only, with the
    estimator's attributes under the same names (``classes_``, ``temperature``,
    ``calibration``, ``calibration_``, ``n_features_in_``); it saves itself as it was loaded."""

    def __init__(self, classes, temperature: float, calibration, n_features: int) -> None:
        self.classes_ = np.asarray(classes)
        self.temperature = float(temperature)
        self.calibration = calibration
        self.calibration_ = checked_calibration(calibration)
        self.n_features_in_ = int(n_features)

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        return {"temperature": self.temperature, "calibration": self.calibration}

    def scores(self, X) -> np.ndarray:
        X = feature_rows(X, self.n_features_in_, "shape-fit model")
        return fit_scores(X, self.classes_, self.calibration_)

    def predict_proba(self, X) -> np.ndarray:
        return probabilities(self.scores(X), self.temperature)

    def predict(self, X) -> np.ndarray:
        return self.classes_[np.argmin(self.scores(X), axis=1)]

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        return state_of(self.temperature, self.calibration, self.classes_, self.n_features_in_)

    @classmethod
    def from_state(cls, state: dict, arrays: dict[str, np.ndarray]) -> ShapeFitVote:
        temperature, calibration, classes, n = checked_state(state, arrays)
        return cls(classes, temperature, calibration, n)
