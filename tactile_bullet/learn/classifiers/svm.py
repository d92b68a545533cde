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
from sklearn.model_selection import StratifiedKFold, cross_val_predict
from sklearn.svm import SVC
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

_F64, _I32 = np.dtype(np.float64), np.dtype(np.int32)
SVC_ARRAYS: dict[str, np.dtype] = {
    "class_weight_": _F64, "classes_": np.dtype(np.intp), "support_": _I32,
    "support_vectors_": _F64, "_n_support": _I32, "dual_coef_": _F64, "intercept_": _F64,
    "_probA": _F64, "_probB": _F64, "_num_iter": _I32, "_intercept_": _F64,
    "_dual_coef_": _F64, "n_iter_": _I32,
}  # fmt: skip
"""The fitted SVC's array attributes (scikit-learn 1.9) and the dtype each must have: libsvm
reads them as typed buffers."""

_NONE, _NUMBER = type(None), (int, float)
SVC_SCALARS: dict[str, tuple[type, ...]] = {
    "decision_function_shape": (str,), "break_ties": (bool,), "kernel": (str,), "degree": (int,),
    "gamma": (str, *_NUMBER), "coef0": _NUMBER, "tol": _NUMBER, "C": _NUMBER, "nu": _NUMBER,
    "epsilon": _NUMBER, "shrinking": (bool,), "probability": (str, bool), "cache_size": _NUMBER,
    "class_weight": (_NONE, str), "verbose": (bool,), "max_iter": (int,),
    "random_state": (_NONE, int), "_sparse": (bool,), "n_features_in_": (int,),
    "_effective_probability": (bool,), "_gamma": _NUMBER, "fit_status_": (int,),
    "shape_fit_": (list,), "_sklearn_version": (str,),
}  # fmt: skip
"""The fitted SVC's other attributes (scikit-learn 1.9), as JSON values of these types
(``shape_fit_`` is a tuple kept as a list, ``_gamma`` a numpy float kept as a float)."""

_PARAMS: dict[str, tuple[type, ...]] = {
    "C": _NUMBER, "kernel": (str,), "gamma": (str, *_NUMBER), "class_weight": (_NONE, str),
    "cv": (int,), "random_state": (_NONE, int),
}  # fmt: skip
_KERNELS = ("linear", "poly", "rbf", "sigmoid")
_OWN_ARRAYS = ("classes", "mean", "scale", "platt")
_SVC_PREFIX = "svc."


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

    def fit(self, X, y):
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
        decision = self.svc_.decision_function((X - self.mean_) / self.scale_)
        if len(self.classes_) == 2:
            a, b = self.platt_[0]
            p = expit(-(a * decision + b))
            return np.column_stack([1.0 - p, p])
        p = expit(-(self.platt_[:, 0] * decision + self.platt_[:, 1]))
        total = p.sum(axis=1, keepdims=True)
        uniform = np.full_like(p, 1.0 / p.shape[1])
        return np.divide(p, total, out=uniform, where=total > 0)

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
        params = {name: _plain(name, getattr(self, name)) for name in _PARAMS}
        scalars: dict = {}
        arrays: dict[str, np.ndarray] = {}
        for name, value in self.svc_.__getstate__().items():
            if isinstance(value, np.ndarray) and value.dtype.kind in "biuf":
                arrays[_SVC_PREFIX + name] = value
            elif isinstance(value, tuple):
                scalars[name] = [_plain(f"SVC {name}", v) for v in value]
            else:
                scalars[name] = _plain(f"SVC {name}", value)
        dtypes = {k.removeprefix(_SVC_PREFIX): v.dtype for k, v in arrays.items()}
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
        """Rebuild a fitted estimator from ``to_state``'s output, checking every kind and
        shape: a damaged file is a ValueError (or KeyError/TypeError), never a crash later."""
        params = state["params"]
        if not isinstance(params, dict) or set(params) != set(_PARAMS):
            raise ValueError(f"svm parameters must be {', '.join(_PARAMS)}")
        for name, value in params.items():
            _check_kind(name, value, _PARAMS[name])
        est = cls(**params)
        n = state["n_features_in"]
        _check_kind("n_features_in", n, (int,))
        if n < 1:
            raise ValueError(f"n_features_in {n} is not a count")
        extra = {k for k in arrays if not k.startswith(_SVC_PREFIX)} - set(_OWN_ARRAYS)
        if extra:
            raise ValueError(f"unknown svm arrays: {', '.join(sorted(extra))}")
        classes = np.asarray(arrays["classes"])
        k = len(classes)
        if classes.ndim != 1 or classes.dtype.kind not in "biuU" or k < 2 \
                or len(np.unique(classes)) != k:  # fmt: skip
            raise ValueError("classes are not 2 or more distinct names or numbers")
        mean, scale, platt = (np.asarray(arrays[name]) for name in ("mean", "scale", "platt"))
        for name, value, shape in (("mean", mean, (n,)), ("scale", scale, (n,)),
                                   ("platt", platt, (1 if k == 2 else k, 2))):  # fmt: skip
            if value.dtype != _F64 or value.shape != shape:
                raise ValueError(f"{name} is {value.dtype} {value.shape}, not float64 {shape}")
            if not np.all(np.isfinite(value)):
                raise ValueError(f"{name} holds non-numbers")
        if np.any(scale <= 0):
            raise ValueError("scale is not positive")
        svc_arrays = {
            name.removeprefix(_SVC_PREFIX): value
            for name, value in arrays.items()
            if name.startswith(_SVC_PREFIX)
        }
        est.svc_ = _restore_svc(state["svc"], svc_arrays, n, k)
        est.mean_, est.scale_, est.platt_, est.classes_ = mean, scale, platt, classes
        est.n_features_in_ = n
        return est


def _plain(name: str, value):
    """``value`` as a JSON scalar (numpy scalars as Python ones); ValueError for anything else."""
    if isinstance(value, np.generic) and value.dtype.kind in "biuf":
        value = value.item()
    if value is None or isinstance(value, str | int | float | bool):
        return value
    raise ValueError(f"{name} is a {type(value).__name__}, which an svm model file does not hold")


def _check_kind(name: str, value, kinds: tuple[type, ...]) -> None:
    """TypeError unless ``value`` is one of ``kinds`` (a bool is not a number here), and
    ValueError for a non-finite float."""
    if (isinstance(value, bool) and bool not in kinds) or not isinstance(value, kinds):
        wanted = " or ".join(k.__name__ for k in kinds)
        raise TypeError(f"{name} is a {type(value).__name__}, not {wanted}")
    if isinstance(value, float) and not np.isfinite(value):
        raise ValueError(f"{name} is not finite")


def _series(version) -> tuple[str, ...] | None:
    """A scikit-learn version's release series (major, minor): a patch release fixes bugs and
    keeps a fitted estimator's attributes, so files move across it."""
    if not isinstance(version, str):
        return None
    return tuple(version.split(".")[:2])


def _restore_svc(scalars: dict, arrays: dict[str, np.ndarray], n: int, k: int) -> SVC:
    """The fitted SVC of ``to_state``'s entries: only the names and kinds scikit-learn 1.9's
    SVC holds, made by this scikit-learn release series, with the shapes libsvm's prediction
    reads."""
    if not isinstance(scalars, dict):
        raise TypeError("the SVC state is not a table")
    made_by = scalars.get("_sklearn_version")
    if _series(made_by) != _series(sklearn.__version__):  # patch releases keep SVC's layout
        raise ValueError(f"the svm was made by scikit-learn {made_by or '(unknown)'}, this is "
                         f"scikit-learn {sklearn.__version__}; retrain the model")  # fmt: skip
    for found, known in ((scalars, SVC_SCALARS), (arrays, SVC_ARRAYS)):
        if set(found) != set(known):
            odd = sorted(set(found) ^ set(known))
            raise ValueError(f"unknown or missing SVC attributes: {', '.join(odd)}")
    for name, kinds in SVC_SCALARS.items():
        _check_kind(name, scalars[name], kinds)
    for name, dtype in SVC_ARRAYS.items():
        if arrays[name].dtype != dtype:
            raise TypeError(f"SVC {name} is {arrays[name].dtype}, not {dtype}")
        if dtype.kind == "f" and not np.all(np.isfinite(arrays[name])):
            raise ValueError(f"SVC {name} holds non-numbers")
    shape_fit = scalars["shape_fit_"]
    if len(shape_fit) != 2 or any(isinstance(v, bool) or not isinstance(v, int)
                                  for v in shape_fit) or shape_fit[1] != n:  # fmt: skip
        raise ValueError(f"SVC shape_fit_ {shape_fit!r} is not (samples, {n})")
    if scalars["n_features_in_"] != n or scalars["kernel"] not in _KERNELS or scalars["_sparse"] \
            or scalars["decision_function_shape"] not in ("ovr", "ovo") \
            or scalars["degree"] < 0 or scalars["cache_size"] <= 0:  # fmt: skip
        raise ValueError("the SVC's settings are not those of a dense SVC on the features")
    pairs = k * (k - 1) // 2
    support, n_support = arrays["support_"], arrays["_n_support"]
    n_sv = len(support)
    shapes = {
        "classes_": (k,), "class_weight_": (k,), "support_": (n_sv,), "_n_support": (k,),
        "support_vectors_": (n_sv, n), "dual_coef_": (k - 1, n_sv), "_dual_coef_": (k - 1, n_sv),
        "intercept_": (pairs,), "_intercept_": (pairs,), "_num_iter": (pairs,),
        "n_iter_": (pairs,),
    }  # fmt: skip
    for name, shape in shapes.items():
        if arrays[name].shape != shape:
            raise ValueError(f"SVC {name} has shape {arrays[name].shape}, not {shape}")
    for name in ("_probA", "_probB"):
        if arrays[name].shape not in ((0,), (pairs,)):
            raise ValueError(f"SVC {name} has shape {arrays[name].shape}, not (0,) or ({pairs},)")
    if not np.array_equal(arrays["classes_"], np.arange(k)):
        raise ValueError("SVC classes_ are not the class indices")
    if n_sv < 1 or np.any(n_support < 0) or int(n_support.sum()) != n_sv:
        raise ValueError("SVC _n_support does not count its support vectors")
    if np.any(support < 0) or np.any(support >= shape_fit[0]):
        raise ValueError("SVC support_ indices lie outside its training set")
    svc = SVC.__new__(SVC)
    with warnings.catch_warnings():  # another patch release of the series: checked above
        warnings.simplefilter("ignore", InconsistentVersionWarning)
        svc.__setstate__({**scalars, **arrays, "shape_fit_": tuple(shape_fit)})
    return svc
