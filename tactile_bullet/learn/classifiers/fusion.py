"""``fusion``: a tree ensemble over the grasp's time series, seconded by the shape fit where the
shape fit explains the grasp as well as it explains the training grasps.

Why two experts. Measured on the benchmark's sets (docs/transfer.md): a forest over the
``time-series`` descriptor trained on randomised grasps transfers between engines (98.3% both
ways) but not to unseen poses (78-83%: trained on centred, unrotated grasps, it takes a
rotated cylinder for a sphere). The training-free shape fit (``perception/shape_fit.py``)
models the object's offset and rotation and holds unseen poses (96.7%), but its coefficients
are Bullet's, so on another engine's grasps it is wrong a quarter of the time. They fail on
different grasps, and the shape fit's own score mostly says which: of its 15 wrong answers on
MuJoCo grasps (trained on randomised Bullet ones) 13 have a best score 1.4-7 times the training
grasps' median, while its right answers on unseen poses have a median of 0.87 times (90% below
1.2).

The combination is a product of experts, per class ``c``::

    log p(c) = log p_trees(c) - weight * trust * (s_c - s_best) / s_ref
    trust    = min(1, (s_ref / s_best) ** sharpness)

``s_c`` is the shape fit's penalised score of class ``c`` (lower is better), ``s_best`` the
grasp's best, ``s_ref`` the median best score over the training grasps (the typical fit on the
hand the model was trained on); the forest's vote shares are floored at ``FLOOR`` so that
neither expert vetoes a class outright. ``trust`` is 1 on a grasp fitted as well as a typical
training grasp and falls fast on one fitted worse (sharpness 8: a fit 1.5 times worse keeps 4%).

``weight`` (``"auto"``) is chosen on the training grasps: every grasp is predicted by trees
fitted on the other folds, and of ``WEIGHTS`` the largest whose held-out accuracy is within
``tolerance`` of the best is kept. The largest, because held-out folds cannot show what the
shape fit is there for: a pose outside the training poses is, by construction, in no fold; among
weights the training grasps cannot tell apart, the one leaning most on the geometry is taken.

Input: the ``time-series+robust-joints`` descriptor (or ``time-series+raw-joints``): the trees
read the time-series columns, the shape fit the joint columns (robust-joints zeroes each joint
on the open hand, so a reading offset is not taken for a shape). Every class must be a shape
the shape fit models. The trees are scikit-learn's extra-trees (``extra-trees`` on its own),
so the method depends on no plugin.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from ..descriptors import raw_joint_names
from .dtw_template import _GENERIC_FIT_CHECKS

WEIGHTS = (0.0, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0)
"""Shape-fit weights ``weight="auto"`` chooses from (0: the trees alone)."""

FLOOR = 1e-3
"""Smallest vote share a class keeps: a class no tree voted for can still win on the
shape fit's evidence, if that is strong and trusted."""

_ANY_FIT = (
    "fusion reads only the time-series+robust-joints layout of registered shape classes; "
    "this check fits it on a generic matrix with integer labels"
)


def joint_columns(n_features: int) -> int:
    """How many trailing columns are joints (raw-joints' or robust-joints' layout, with or
    without the thumb), given the time-series columns before them."""
    for thumb in (False, True):
        width = len(raw_joint_names(thumb))
        if n_features > width and (n_features - width) % width == 0:
            return width
    raise ValueError(
        f"fusion expects the time-series+robust-joints descriptor's columns (time series, then "
        f"{len(raw_joint_names(False))} or {len(raw_joint_names(True))} joints), got {n_features}"
    )


def fuse(log_trees: np.ndarray, scores: np.ndarray, weight: float, reference: float,
         sharpness: float) -> np.ndarray:  # fmt: skip
    """(n, n_classes) fused log-probabilities (unnormalised) from the trees' log vote shares
    and the shape fit's scores (module docstring)."""
    scores = np.asarray(scores, dtype=float)
    best = scores.min(axis=1, keepdims=True)
    trust = np.minimum(1.0, (reference / np.maximum(best, 1e-12)) ** sharpness)
    return np.asarray(log_trees, float) - weight * trust * (scores - best) / reference


class FusionClassifier(ClassifierMixin, BaseEstimator):
    """Extra-trees on the time series x the shape fit, trusted where it fits well.

    Parameters: ``n_estimators`` trees (seeded by ``random_state``); ``weight`` of the shape
    fit (``"auto"``: chosen on training folds, ``folds`` of them, within ``tolerance`` of the
    best held-out accuracy); ``sharpness`` of the trust.
    Fitted attributes: ``classes_``, ``trees_``, ``weight_``, ``reference_score_`` (NaN with
    weight 0), ``held_out_accuracy_`` (weight -> accuracy, empty with a given weight).
    """

    required_descriptor = "time-series+robust-joints"
    """The layout this classifier reads: time-series columns, then the joints."""
    accepted_descriptors = ("time-series+raw-joints",)
    """Same columns, the joints not zeroed on the open hand."""
    trusted_types = ("tactile_bullet.learn.classifiers.shape_fit.ShapeFitClassifier",)
    """What a saved model holds besides scikit-learn's own types (``learn/models.py``)."""

    def __init__(self, n_estimators=100, weight="auto", sharpness=8.0, tolerance=0.01,
                 folds=3, random_state=0):  # fmt: skip
        self.n_estimators = n_estimators
        self.weight = weight
        self.sharpness = sharpness
        self.tolerance = tolerance
        self.folds = folds
        self.random_state = random_state

    def expected_failed_checks(self) -> dict[str, str]:
        """scikit-learn checks that cannot apply, with the reason (see tests)."""
        return dict.fromkeys(_GENERIC_FIT_CHECKS, _ANY_FIT)

    def _check_params(self) -> None:
        n = self.n_estimators
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
            raise ValueError(f"n_estimators must be an integer >= 1, got {n!r}")
        w = self.weight
        number = not isinstance(w, bool) and isinstance(w, int | float)
        if not (w == "auto" if isinstance(w, str) else number and np.isfinite(w) and w >= 0):
            raise ValueError(f"weight must be 'auto' or a number >= 0, got {w!r}")
        if not (np.isfinite(self.sharpness) and self.sharpness >= 0):
            raise ValueError(f"sharpness must be a number >= 0, got {self.sharpness!r}")
        if not (0 <= self.tolerance < 1):
            raise ValueError(f"tolerance must be from 0 to below 1, got {self.tolerance!r}")
        if isinstance(self.folds, bool) or not isinstance(self.folds, int) or self.folds < 2:
            raise ValueError(f"folds must be an integer >= 2, got {self.folds!r}")

    def _trees(self):
        from sklearn.ensemble import ExtraTreesClassifier

        return ExtraTreesClassifier(n_estimators=self.n_estimators,
                                    random_state=self.random_state)  # fmt: skip

    def _log_votes(self, trees, X: np.ndarray) -> np.ndarray:
        """Log vote shares in ``classes_`` order (a fold's trees may lack a class)."""
        out = np.full((len(X), len(self.classes_)), FLOOR)
        cols = np.searchsorted(self.classes_, trees.classes_)
        out[:, cols] = np.maximum(trees.predict_proba(X), FLOOR)
        return np.log(out)

    def fit(self, X, y):
        X, y = validate_data(self, X, y)
        check_classification_targets(y)
        self._check_params()
        width = joint_columns(X.shape[1])
        from .shape_fit import ShapeFitClassifier

        self.classes_, counts = np.unique(y, return_counts=True)
        if self.weight == "auto" and counts.min() < 2:  # before the shape fits, not after
            raise ValueError(
                "fusion needs at least 2 training grasps of each shape to choose its weight "
                "on held-out folds (or set weight to a number)"
            )
        self.shape_fit_ = ShapeFitClassifier().fit(X[:, -width:], y)  # checks the classes
        series = X[:, :-width]
        self.held_out_accuracy_ = {}
        self.weight_ = 0.0 if self.weight == "auto" else float(self.weight)
        self.reference_score_ = float("nan")  # weight 0: the shape fit has no say
        if self.weight == "auto" or self.weight_ > 0:
            scores = self.shape_fit_.scores(X[:, -width:])
            self.reference_score_ = float(np.median(scores.min(axis=1)))
            if self.weight == "auto":
                self.weight_ = self._choose_weight(series, y, scores, int(counts.min()))
        self.trees_ = self._trees().fit(series, y)
        return self

    def _choose_weight(self, series: np.ndarray, y: np.ndarray, scores: np.ndarray,
                       fewest: int) -> float:  # fmt: skip
        """The weight (``fewest``: grasps of the rarest shape, >= 2, checked in fit)."""
        from sklearn.model_selection import StratifiedKFold

        split = StratifiedKFold(min(self.folds, fewest), shuffle=True, random_state=0)
        log_votes = np.empty((len(y), len(self.classes_)))
        for train, held in split.split(series, y):
            trees = self._trees().fit(series[train], y[train])
            log_votes[held] = self._log_votes(trees, series[held])
        for w in WEIGHTS:
            fused = fuse(log_votes, scores, w, self.reference_score_, self.sharpness)
            right = self.classes_[np.argmax(fused, axis=1)] == y
            self.held_out_accuracy_[w] = float(np.mean(right))
        best = max(self.held_out_accuracy_.values())
        return max(w for w, a in self.held_out_accuracy_.items()
                   if a >= best - self.tolerance - 1e-12)  # fmt: skip

    def _fused(self, X) -> np.ndarray:
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        width = joint_columns(X.shape[1])
        log_votes = self._log_votes(self.trees_, X[:, :-width])
        if self.weight_ == 0:  # the trees alone: no shape fit to run
            return log_votes
        scores = self.shape_fit_.scores(X[:, -width:])
        return fuse(log_votes, scores, self.weight_, self.reference_score_, self.sharpness)

    def predict_proba(self, X) -> np.ndarray:
        z = self._fused(X)
        p = np.exp(z - z.max(axis=1, keepdims=True))
        return p / p.sum(axis=1, keepdims=True)

    def predict(self, X) -> np.ndarray:
        z = self._fused(X)  # checks fitted before classes_ is read
        return self.classes_[np.argmax(z, axis=1)]
