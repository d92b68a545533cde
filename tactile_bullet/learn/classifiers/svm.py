"""``svm``: RBF support vector machine on standardised features (thesis 2.4, SVM).

Probabilities come from Platt scaling done here rather than through scikit-learn's
``CalibratedClassifierCV``: the same method (one sigmoid per class fitted on cross-validated
decision values, one SVC fitted on all the data), but a prediction is a few array operations
instead of a dozen validation passes, which keeps one grasp's identification well under the
5 ms target. (``SVC(probability=True)`` is deprecated since scikit-learn 1.9.)

It saves itself as JSON values and numeric arrays (``to_state``, learn/models.py's state
protocol) rather than through skops, whose import alone costs ~2 s of every ``evaluate`` and
``identify``: the fitted SVC is its ``__getstate__`` dict, restored from a fixed list of the
attribute names and kinds scikit-learn 1.9's SVC holds, every shape checked against the others
(libsvm reads them unchecked), and only by the scikit-learn version that wrote it.
"""

from __future__ import annotations

import warnings

import numpy as np
import sklearn
from scipy.special import expit
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.exceptions import InconsistentVersionWarning
from sklearn.svm import SVC
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from ..svm_state import (
    PARAMS,
    SVC_ARRAYS,
    SVC_PREFIX,
    SVC_SCALARS,
    SVMState,
    check_state,
    plain,
    platt_proba,
)


def platt_sigmoid(decision: np.ndarray, positive: np.ndarray) -> tuple[float, float]:
    """(A, B) of p = 1 / (1 + exp(A f + B)) fitted to 0/1 targets by Platt's method: Newton
    steps with backtracking on the log loss, targets smoothed toward the class priors so that
    separable data does not drive A to infinity (Lin, Lin and Weng's version of Platt 1999)."""
    f = np.asarray(decision, dtype=float)
    t = np.asarray(positive, dtype=bool)
    n_pos = float(t.sum())
    n_neg = float(t.size - n_pos)
    target = np.where(t, (n_pos + 1.0) / (n_pos + 2.0), 1.0 / (n_neg + 2.0))

    def loss(ab: np.ndarray) -> float:
        z = ab[0] * f + ab[1]
        return float(np.sum(target * np.logaddexp(0.0, z) + (1.0 - target) * np.logaddexp(0.0, -z)))

    ab = np.array([0.0, np.log((n_neg + 1.0) / (n_pos + 1.0))])
    value = loss(ab)
    for _ in range(100):
        z = ab[0] * f + ab[1]
        p = expit(z)
        g = p - (1.0 - target)
        grad = np.array([g @ f, g.sum()])
        if np.max(np.abs(grad)) < 1e-6:
            break
        w = p * (1.0 - p)
        hess = np.array([[w @ (f * f), w @ f], [w @ f, w.sum()]]) + 1e-12 * np.eye(2)
        step = np.linalg.solve(hess, grad)
        size = 1.0
        while size > 1e-10:
            trial = ab - size * step
            trial_value = loss(trial)
            if trial_value < value + 1e-4 * size * (grad @ -step):
                break
            size /= 2.0
        else:
            break
        ab, value = trial, trial_value
    return float(ab[0]), float(ab[1])


class SVMClassifier(ClassifierMixin, BaseEstimator):
    """StandardScaler + SVC + Platt probabilities; ``predict`` is the most probable class.

    ``C`` defaults to 100: signatures are deterministic, low-noise curves, so a hard margin
    fits them better than scikit-learn's C=1. Signature + svm, mean over six splits of the
    demo protocol (``python benchmarks/bench_accuracy.py --seeds 0,1,2,3,4,5 --param C=...``, 600
    held-out grasps in all): 87.3% at C=10, 91.2% at 30, 95.8% at 100, 96.7% at 300. ``cv``
    folds (fewer when a class is smaller) give the decision values the sigmoids are fitted on;
    ``random_state`` seeds their shuffling.

    Fitted attributes: ``svc_``, ``mean_``/``scale_`` (standardisation), ``platt_`` (A, B) per
    class (one row for two classes).
    """

    def __init__(
        self, C=100.0, kernel="rbf", gamma="scale", class_weight=None, cv=3, random_state=0
    ):
        self.C = C
        self.kernel = kernel
        self.gamma = gamma
        self.class_weight = class_weight
        self.cv = cv
        self.random_state = random_state

    def expected_failed_checks(self) -> dict[str, str]:
        """scikit-learn checks that cannot pass, with the reason (the test suite reads this)."""
        return {
            "check_class_weight_classifiers": (
                "predict is the most probable class after Platt scaling, which class_weight "
                "does not reweight; the check expects the decision function's vote"
            ),
        }

    def _svc(self) -> SVC:
        return SVC(C=self.C, kernel=self.kernel, gamma=self.gamma, class_weight=self.class_weight)

    def check_params(self) -> None:
        """SVC's own check of ``C``, ``kernel``, ``gamma`` and ``class_weight`` (a ValueError
        naming the value), before any fit rather than inside the first one."""
        self._svc()._validate_params()

    def fit(self, X, y):
        from sklearn.model_selection import StratifiedKFold, cross_val_predict

        X, y = validate_data(self, X, y)
        check_classification_targets(y)
        if isinstance(self.cv, bool) or not isinstance(self.cv, int | np.integer) or self.cv < 2:
            raise ValueError(f"svm cv must be an integer >= 2, got {self.cv!r}")
        classes, y_index = np.unique(y, return_inverse=True)
        if len(classes) < 2:
            raise ValueError("svm needs at least 2 classes; the data holds 1 class")
        smallest = int(np.bincount(y_index).min())
        if smallest < 2:
            raise ValueError(
                f"svm needs at least 2 samples of every class to calibrate (got {smallest} sample)"
            )
        self.mean_ = X.mean(axis=0)
        scale = X.std(axis=0)
        self.scale_ = np.where(scale > 0, scale, 1.0)
        Z = (X - self.mean_) / self.scale_
        folds = StratifiedKFold(
            min(int(self.cv), smallest), shuffle=True, random_state=self.random_state
        )
        decision = cross_val_predict(self._svc(), Z, y_index, cv=folds, method="decision_function")
        if len(classes) == 2:
            self.platt_ = np.array([platt_sigmoid(decision, y_index == 1)])
        else:
            self.platt_ = np.array(
                [platt_sigmoid(decision[:, k], y_index == k) for k in range(len(classes))]
            )
        self.svc_ = self._svc().fit(Z, y_index)
        self.classes_ = classes
        return self

    def predict_proba(self, X) -> np.ndarray:
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        return platt_proba(self.svc_.decision_function((X - self.mean_) / self.scale_),
                           self.platt_)  # fmt: skip

    def predict(self, X) -> np.ndarray:
        proba = self.predict_proba(X)
        return self.classes_[np.argmax(proba, axis=1)]

    # -- saving (learn/models.py's state protocol) -------------------------------------------

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Parameters and the SVC's scalars as JSON, its arrays and the standardisation and
        sigmoids as numeric arrays. ValueError for a value of another kind (a dict
        ``class_weight``, a callable kernel): nothing else is ever written.
        NotImplementedError where this scikit-learn's SVC holds other attributes than the
        ones :meth:`from_state` restores (another version): models.py then writes skops."""
        check_is_fitted(self)
        params = {name: plain(name, getattr(self, name)) for name in PARAMS}
        scalars: dict = {}
        arrays: dict[str, np.ndarray] = {}
        for name, value in self.svc_.__getstate__().items():
            if isinstance(value, np.ndarray) and value.dtype.kind in "biuf":
                arrays[SVC_PREFIX + name] = value
            elif isinstance(value, tuple):
                scalars[name] = [plain(f"SVC {name}", v) for v in value]
            else:
                scalars[name] = plain(f"SVC {name}", value)
        dtypes = {k.removeprefix(SVC_PREFIX): v.dtype for k, v in arrays.items()}
        if set(scalars) != set(SVC_SCALARS) or dtypes != SVC_ARRAYS:
            raise NotImplementedError(
                f"scikit-learn {sklearn.__version__}'s SVC holds other attributes than those "
                "of scikit-learn 1.9 that svm restores"
            )
        classes = np.asarray(self.classes_)
        if classes.dtype.kind not in "biuU":
            classes = classes.astype(str)
        arrays |= {"classes": classes, "mean": np.asarray(self.mean_, dtype=float),
                   "scale": np.asarray(self.scale_, dtype=float),
                   "platt": np.asarray(self.platt_, dtype=float)}  # fmt: skip
        state = {"params": params, "n_features_in": int(self.n_features_in_), "svc": scalars}
        return state, arrays

    @classmethod
    def from_state(cls, state: dict, arrays: dict[str, np.ndarray]) -> SVMClassifier:
        """Rebuild a fitted estimator from ``to_state``'s output, checked in every kind and
        shape (``svm_state.check_state``): a damaged file is a ValueError (or KeyError,
        TypeError), never a crash later."""
        st = check_state(state, arrays)
        est = cls(**st.params)
        est.svc_ = _restore_svc(st)
        est.mean_, est.scale_, est.platt_, est.classes_ = st.mean, st.scale, st.platt, st.classes
        est.n_features_in_ = st.n_features
        return est


def _restore_svc(st: SVMState) -> SVC:
    """The fitted SVC of a checked state (``svm_state.check_state``)."""
    svc = SVC.__new__(SVC)
    shape_fit = st.svc_scalars["shape_fit_"]
    with warnings.catch_warnings():  # another patch release of the series: checked before
        warnings.simplefilter("ignore", InconsistentVersionWarning)
        svc.__setstate__({**st.svc_scalars, **st.svc_arrays, "shape_fit_": tuple(shape_fit)})
    return svc
