"""``dtw-template``: the training-free identifier (thesis 2.3.1) as an estimator.

Each class must be a registered shape; its templates are that shape's theoretical signatures,
and a grasp goes to the nearest by DTW (``patterns.identify``, with the measured integral rule
between hyperboloid and cylinder). Without a size cue the template is the pattern at the
shape's default size (the thesis' library); when the signature descriptor carries its level
column (``level=True``) each class holds a family of sizes (``patterns.pattern_family``) and
the member at the level the hand felt is compared, as ``tactile-bullet grasp`` identifies.
``fit`` learns nothing: it records the classes and builds their templates, so a model can be
"trained" on a handful of grasps and still be a fair baseline. It reads the ``signature``
descriptor's layout (lines, bulges[, alphas][, level]) and nothing else.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from ..descriptors import SIGNATURE_LINE_POINTS

_GENERIC_FIT_CHECKS = (
    "check_classifier_data_not_an_array", "check_classifiers_classes",
    "check_classifiers_one_label", "check_classifiers_train", "check_dict_unchanged",
    "check_dont_overwrite_parameters", "check_dtype_object", "check_estimators_dtypes",
    "check_estimators_fit_returns_self", "check_estimators_nan_inf",
    "check_estimators_overwrite_params", "check_estimators_pickle",
    "check_f_contiguous_array_estimator", "check_fit2d_1feature", "check_fit2d_1sample",
    "check_fit2d_predict1d", "check_fit_check_is_fitted", "check_fit_idempotent",
    "check_fit_score_takes_y", "check_methods_sample_order_invariance",
    "check_methods_subset_invariance", "check_n_features_in",
    "check_n_features_in_after_fitting", "check_pipeline_consistency",
    "check_positive_only_tag_during_fit", "check_readonly_memmap_input",
    "check_supervised_y_2d",
)  # fmt: skip
"""scikit-learn checks that fit on a small generic matrix: none can give this estimator
signature columns with shape-name labels, so each fails at fit by design."""

_ANY_FIT = (
    "dtw-template reads only the signature descriptor's columns of registered shape classes; "
    "this check fits it on a generic matrix with integer labels"
)


def _signature(lower, upper, bulge_lower=0.0, bulge_upper=0.0, level=0.0):
    """A Signature holding what identification reads: lines, bulges and the raw upper level."""
    from ...perception.signature import Signature

    return Signature(
        lower=np.asarray(lower, dtype=float),
        upper=np.asarray(upper, dtype=float),
        alpha_lower=0.0,
        alpha_upper=0.0,
        bulge_lower=float(bulge_lower),
        bulge_upper=float(bulge_upper),
        raw_lower=np.zeros(1),
        raw_upper=np.array([float(level)]),
        fci=np.zeros((3, 4)),
    )


class DTWTemplateClassifier(ClassifierMixin, BaseEstimator):
    """Nearest theoretical signature by DTW.

    Parameters: ``points`` samples per line (must match the signature descriptor's);
    ``temperature`` turns distances
    into probabilities, p ~ exp(-d / temperature); ``integral_rule`` applies the bulge rule
    between hyperboloid and cylinder (thesis Fig. 2.22).

    Fitted attributes: ``classes_``; ``templates_`` (m, 2, points) the lines compared,
    ``template_class_`` (m,) the class index of each and ``template_level_`` (m,) its level.
    """

    required_descriptor = "signature"
    """The only descriptor whose columns this classifier understands."""
    accepted_descriptors = ("coupled-signature",)
    """The same columns, from J3 and J0 only (``learn/coupled.py``)."""

    def __init__(self, points=SIGNATURE_LINE_POINTS, temperature=1.0, integral_rule=True):
        self.points = points
        self.temperature = temperature
        self.integral_rule = integral_rule

    def expected_failed_checks(self) -> dict[str, str]:
        """scikit-learn checks that cannot apply, with the reason (see tests)."""
        return dict.fromkeys(_GENERIC_FIT_CHECKS, _ANY_FIT)

    def _check_layout(self, n_features: int) -> None:
        p = self.points
        if isinstance(p, bool) or not isinstance(p, int | np.integer) or p < 3:
            raise ValueError(f"dtw-template points must be an integer >= 3, got {p!r}")
        if not 2 * p + 2 <= n_features <= 2 * p + 5:
            raise ValueError(
                f"dtw-template expects the signature descriptor's {2 * p + 2} to {2 * p + 5} "
                f"columns (2 lines x {p} points, 2 bulges, optional 2 alphas and level), "
                f"got {n_features}"
            )
        if not (np.isfinite(self.temperature) and self.temperature > 0):
            raise ValueError(f"temperature must be a positive number, got {self.temperature!r}")

    def fit(self, X, y):
        X, y = validate_data(self, X, y)
        check_classification_targets(y)
        self._check_layout(X.shape[1])
        from ...perception import patterns
        from ...perception.signature import resample_line
        from ...plugins import get_shape

        self.classes_ = np.unique(y)
        sized = self._has_level(X.shape[1])
        templates, owners, levels = [], [], []
        for index, label in enumerate(self.classes_):
            try:
                shape = get_shape(str(label))
            except ValueError:
                raise ValueError(
                    f"dtw-template has no theoretical pattern for class {label!r}: "
                    "classes must be registered shape names"
                ) from None
            family = patterns.pattern_family(shape) if sized else (patterns.pattern(shape),)
            for ref in family:
                templates.append(
                    [resample_line(ref.lower, self.points), resample_line(ref.upper, self.points)]
                )
                owners.append(index)
                levels.append(float(np.mean(ref.raw_upper)))
        self.templates_ = np.asarray(templates, dtype=float)
        self.template_class_ = np.asarray(owners, dtype=int)
        self.template_level_ = np.asarray(levels, dtype=float)
        return self

    def _has_level(self, n_features: int) -> bool:
        """Whether the last column is the level: 1 or 3 columns after the lines and bulges."""
        return (n_features - 2 * int(self.points) - 2) in (1, 3)

    def distances(self, X) -> np.ndarray:
        """(n, n_classes) DTW distances to each class template, after the integral rule
        (which swaps the hyperboloid/cylinder pair so that its choice is the nearer)."""
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        from ...perception import patterns

        p = self.points
        names = [str(c) for c in self.classes_]
        library = {
            name: tuple(
                _signature(lines[0], lines[1], level=level)
                for lines, owner, level in zip(
                    self.templates_, self.template_class_, self.template_level_, strict=True
                )
                if owner == index
            )
            for index, name in enumerate(names)
        }
        # every class is a candidate: no "unknown" beyond a correspondence threshold
        thresholds = dataclasses.replace(patterns.load_thresholds(), correspondence=float("inf"))
        pair = patterns.INTEGRAL_PAIR
        sized = self._has_level(X.shape[1])
        out = np.empty((len(X), len(names)))
        for row, x in enumerate(X):
            level = x[-1] if sized else 0.0
            sig = _signature(x[:p], x[p : 2 * p], x[2 * p], x[2 * p + 1], level)
            if self.integral_rule:
                ident = patterns.identify(sig, library, thresholds)
                dist = ident.distances
            else:
                dist = {
                    n: patterns.signature_distance(sig, patterns.closest_in_size(sig, family))
                    for n, family in library.items()
                }
                ident = None
            if ident is not None and ident.integral_rule:
                near, far = sorted(dist[n] for n in pair)
                other = pair[1] if ident.name == pair[0] else pair[0]
                dist = {**dist, ident.name: near, other: far}
            out[row] = [dist[n] for n in names]
        return out

    def predict_proba(self, X) -> np.ndarray:
        d = self.distances(X)
        logits = -(d - d.min(axis=1, keepdims=True)) / float(self.temperature)
        weights = np.exp(logits)
        return weights / weights.sum(axis=1, keepdims=True)

    def predict(self, X) -> np.ndarray:
        proba = self.predict_proba(X)
        return self.classes_[np.argmax(proba, axis=1)]
