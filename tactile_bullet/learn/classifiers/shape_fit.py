"""``shape-fit``: the second training-free identifier (``shape_fit.fit_shape``) as an estimator.

Each class must be a registered shape with a radius profile; a grasp goes to the class whose
family, fitted in size and position to the grasp's absolute J3 and J1 + J2 angles, scores best.
``fit`` learns nothing: it records the classes, so the estimator is a fair training-free
baseline in ``compare`` and ``train``. It reads the ``raw-joints`` descriptor's columns (with or
without the thumb), or ``robust-joints`` (the same columns zeroed on the open hand, the input
to use on a real hand), and nothing else.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from ...hand import LONG_FINGERS
from ..descriptors import raw_joint_names
from .dtw_template import _GENERIC_FIT_CHECKS

_ANY_FIT = (
    "shape-fit reads only the raw-joints layout's columns of registered shape classes; "
    "this check fits it on a generic matrix with integer labels"
)


def _fci_columns(n_features: int) -> np.ndarray:
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


def _calibration(doc):
    """The ``calibration`` parameter as coefficients (None: those in force when fitting), every
    value checked as a hand calibration file's are (ValueError, one line, otherwise)."""
    if doc is None:
        return None
    from dataclasses import replace

    from ...errors import UsageError
    from ...realhand.hand_calibration import checked_coefficients

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


class ShapeFitClassifier(ClassifierMixin, BaseEstimator):
    """Best penalised fit of each class's shape family to the absolute joint angles.

    Parameters: ``temperature`` turns fit scores into probabilities, p ~ exp(-score / T);
    ``calibration`` is None (the coefficients in force: the shipped ones, or ``--hand-
    calibration``'s) or a hand's coefficients as ``Calibration.to_dict`` gives them, plus
    ``angles`` (``raw``/``zeroed``): the model then carries its hand's calibration inside it
    (``adapt`` writes such models), and no flag is needed to read that hand.
    Fitted attributes: ``classes_``, ``calibration_`` (None or the ``Calibration``).
    """

    required_descriptor = "raw-joints"
    """The descriptor whose columns this classifier understands."""
    accepted_descriptors = ("robust-joints",)
    """Same columns, read zeroed on the open hand (``learn/robust.py``): a per-joint calibration
    bias, which the fit would otherwise take for a shape, is gone before the fit."""

    def __init__(self, temperature=1.0, calibration=None):
        self.temperature = temperature
        self.calibration = calibration

    def expected_failed_checks(self) -> dict[str, str]:
        """scikit-learn checks that cannot apply, with the reason (see tests)."""
        return dict.fromkeys(_GENERIC_FIT_CHECKS, _ANY_FIT)

    def fit(self, X, y):
        X, y = validate_data(self, X, y)
        check_classification_targets(y)
        _fci_columns(X.shape[1])
        if not (np.isfinite(self.temperature) and self.temperature > 0):
            raise ValueError(f"temperature must be a positive number, got {self.temperature!r}")
        from ...perception import shape_fit

        self.calibration_ = _calibration(self.calibration)
        self.classes_ = np.unique(y)
        for label in self.classes_:
            if str(label) not in shape_fit.fitted_shapes():
                raise ValueError(
                    f"shape-fit has no model of class {label!r}: classes must be shape names "
                    f"({', '.join(shape_fit.fitted_shapes())})"
                )
        return self

    def scores(self, X) -> np.ndarray:
        """(n, n_classes) penalised fit scores (lower is better)."""
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        from ...perception.fit_batch import fit_many

        cols = _fci_columns(X.shape[1])
        names = [str(c) for c in self.classes_]
        # kept per grasp: predict, then proba
        fits = fit_many([x[cols] for x in X], names, self.calibration_)
        return np.array([[fit.fits[n].score for n in names] for fit in fits]).reshape(
            len(X), len(names)
        )

    def predict_proba(self, X) -> np.ndarray:
        s = self.scores(X)
        weights = np.exp(-(s - s.min(axis=1, keepdims=True)) / float(self.temperature))
        return weights / weights.sum(axis=1, keepdims=True)

    def predict(self, X) -> np.ndarray:
        best = np.argmin(self.scores(X), axis=1)  # checks fitted before classes_ is read
        return self.classes_[best]

    # -- saving (learn/models.py's state protocol) -------------------------------------------

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Its temperature and classes: a model of it is a few bytes, saved and read without
        skops (whose import alone costs ~3 s of every train and evaluate of it)."""
        check_is_fitted(self)
        state = {"params": {"temperature": float(self.temperature),
                            "calibration": self.calibration},
                 "n_features_in": int(self.n_features_in_)}  # fmt: skip
        return state, {"classes": np.asarray(self.classes_).astype(str)}

    @classmethod
    def from_state(cls, state: dict, arrays: dict[str, np.ndarray]) -> ShapeFitClassifier:
        """Rebuild a fitted estimator from ``to_state``'s output, checking every value."""
        from ...perception import shape_fit

        temperature = state["params"]["temperature"]
        if isinstance(temperature, bool) or not isinstance(temperature, int | float) \
                or not (np.isfinite(temperature) and temperature > 0):  # fmt: skip
            raise ValueError(f"temperature {temperature!r} is not a positive number")
        n = state["n_features_in"]
        if not isinstance(n, int) or isinstance(n, bool):
            raise ValueError(f"n_features_in {n!r} is not a count")
        _fci_columns(n)  # a layout the fit reads, else ValueError
        classes = np.asarray(arrays["classes"])
        if classes.ndim != 1 or len(classes) < 1 or classes.dtype.kind != "U":
            raise ValueError("classes must be a list of shape names")
        unknown = sorted(set(classes.tolist()) - set(shape_fit.fitted_shapes()))
        if unknown:
            raise ValueError(f"class {unknown[0]!r} is not a shape the fit models")
        est = cls(temperature=float(temperature), calibration=state["params"]["calibration"])
        est.calibration_ = _calibration(est.calibration)
        est.classes_ = classes
        est.n_features_in_ = n
        return est
