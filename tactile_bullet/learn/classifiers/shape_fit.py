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

from ..shape_fit_vote import (
    checked_calibration,
    checked_state,
    fci_columns,
    fit_scores,
    probabilities,
    state_of,
)
from .dtw_template import _GENERIC_FIT_CHECKS

_ANY_FIT = (
    "shape-fit reads only the raw-joints layout's columns of registered shape classes; "
    "this check fits it on a generic matrix with integer labels"
)


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
        fci_columns(X.shape[1])
        if not (np.isfinite(self.temperature) and self.temperature > 0):
            raise ValueError(f"temperature must be a positive number, got {self.temperature!r}")
        from ...perception import shape_fit

        self.calibration_ = checked_calibration(self.calibration)
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
        return fit_scores(X, self.classes_, self.calibration_)

    def predict_proba(self, X) -> np.ndarray:
        return probabilities(self.scores(X), self.temperature)

    def predict(self, X) -> np.ndarray:
        best = np.argmin(self.scores(X), axis=1)  # checks fitted before classes_ is read
        return self.classes_[best]

    # -- saving (learn/models.py's state protocol) -------------------------------------------

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Its temperature and classes: a model of it is a few bytes, saved and read without
        skops (whose import alone costs ~3 s of every train and evaluate of it). A saved model
        loads as the numpy :class:`~tactile_bullet.learn.shape_fit_vote.ShapeFitVote`."""
        check_is_fitted(self)
        return state_of(self.temperature, self.calibration, self.classes_, self.n_features_in_)

    @classmethod
    def from_state(cls, state: dict, arrays: dict[str, np.ndarray]) -> ShapeFitClassifier:
        """Rebuild a fitted estimator from ``to_state``'s output, checking every value."""
        temperature, calibration, classes, n = checked_state(state, arrays)
        est = cls(temperature=temperature, calibration=calibration)
        est.calibration_ = checked_calibration(calibration)
        est.classes_ = classes
        est.n_features_in_ = n
        return est
