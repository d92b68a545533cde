"""An svm model file's state, checked without scikit-learn, and the predict-only form a saved
svm loads as (:class:`SVMVote`, the registry's ``fitted_form`` for ``svm``).

The default identifier is an svm, and importing scikit-learn's SVC costs ~0.9 s, most of a
command-line grasp's budget beyond its simulation. A loaded svm therefore answers here, in
numpy: the kernel values against the support vectors, libsvm's one-against-one decision values,
scikit-learn's one-against-rest rule over them (votes, ties broken by the summed confidences
squashed into (-1/3, 1/3)), then the classifier's own Platt sigmoids. Fitting stays with
scikit-learn (``classifiers/svm.py``); tests hold the two within 1e-9 on every kernel, the
answers equal.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .rows import feature_rows

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

PARAMS: dict[str, tuple[type, ...]] = {
    "C": _NUMBER, "kernel": (str,), "gamma": (str, *_NUMBER), "class_weight": (_NONE, str),
    "cv": (int,), "random_state": (_NONE, int),
}  # fmt: skip
KERNELS = ("linear", "poly", "rbf", "sigmoid")
OWN_ARRAYS = ("classes", "mean", "scale", "platt")
SVC_PREFIX = "svc."


def installed_sklearn() -> str:
    """The installed scikit-learn's version, read without importing it."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("scikit-learn")
    except PackageNotFoundError:
        return "(not installed)"


def plain(name: str, value):
    """``value`` as a JSON scalar (numpy scalars as Python ones); ValueError for anything else."""
    if isinstance(value, np.generic) and value.dtype.kind in "biuf":
        value = value.item()
    if value is None or isinstance(value, str | int | float | bool):
        return value
    raise ValueError(f"{name} is a {type(value).__name__}, which an svm model file does not hold")


def check_kind(name: str, value, kinds: tuple[type, ...]) -> None:
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


@dataclass(frozen=True)
class SVMState:
    """A checked svm state: what both the estimator and :class:`SVMVote` are built from."""

    params: dict[str, Any]
    n_features: int
    classes: np.ndarray
    mean: np.ndarray
    scale: np.ndarray
    platt: np.ndarray
    svc_scalars: dict[str, Any]
    svc_arrays: dict[str, np.ndarray]


def check_state(
    state: dict, arrays: dict[str, np.ndarray], for_libsvm: bool = True
) -> SVMState:
    """``to_state``'s output checked in every kind and shape: a damaged file is a ValueError
    (or KeyError/TypeError), never a crash later in libsvm or here. ``for_libsvm``: the state
    will be handed to scikit-learn's SVC, which reads its arrays as that release series laid
    them out, so it must come from the installed series; :class:`SVMVote` reads the arrays
    itself, by their checked shapes, under any scikit-learn (the shipped default is an svm)."""
    params = state["params"]
    if not isinstance(params, dict) or set(params) != set(PARAMS):
        raise ValueError(f"svm parameters must be {', '.join(PARAMS)}")
    for name, value in params.items():
        check_kind(name, value, PARAMS[name])
    n = state["n_features_in"]
    check_kind("n_features_in", n, (int,))
    if n < 1:
        raise ValueError(f"n_features_in {n} is not a count")
    extra = {k for k in arrays if not k.startswith(SVC_PREFIX)} - set(OWN_ARRAYS)
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
    svc_arrays = {name.removeprefix(SVC_PREFIX): value for name, value in arrays.items()
                  if name.startswith(SVC_PREFIX)}  # fmt: skip
    scalars = state["svc"]
    _check_svc(scalars, svc_arrays, n, k, installed_sklearn() if for_libsvm else None)
    return SVMState(dict(params), n, classes, mean, scale, platt, scalars, svc_arrays)


def _check_svc(scalars: dict, arrays: dict[str, np.ndarray], n: int, k: int,
               installed: str | None) -> None:  # fmt: skip
    """The fitted SVC's entries: only the names and kinds scikit-learn 1.9's SVC holds, made by
    the installed scikit-learn's release series, with the shapes libsvm's prediction reads."""
    if not isinstance(scalars, dict):
        raise TypeError("the SVC state is not a table")
    made_by = scalars.get("_sklearn_version")
    if not isinstance(made_by, str):
        raise TypeError("the SVC state does not say which scikit-learn made it")
    if installed is not None and _series(made_by) != _series(installed):  # patch: same layout
        raise ValueError(f"the svm was made by scikit-learn {made_by or '(unknown)'}, this is "
                         f"scikit-learn {installed}; retrain the model")  # fmt: skip
    for found, known in ((scalars, SVC_SCALARS), (arrays, SVC_ARRAYS)):
        if set(found) != set(known):
            odd = sorted(set(found) ^ set(known))
            raise ValueError(f"unknown or missing SVC attributes: {', '.join(odd)}")
    for name, kinds in SVC_SCALARS.items():
        check_kind(name, scalars[name], kinds)
    for name, dtype in SVC_ARRAYS.items():
        if arrays[name].dtype != dtype:
            raise TypeError(f"SVC {name} is {arrays[name].dtype}, not {dtype}")
        if dtype.kind == "f" and not np.all(np.isfinite(arrays[name])):
            raise ValueError(f"SVC {name} holds non-numbers")
    shape_fit = scalars["shape_fit_"]
    if len(shape_fit) != 2 or any(isinstance(v, bool) or not isinstance(v, int)
                                  for v in shape_fit) or shape_fit[1] != n:  # fmt: skip
        raise ValueError(f"SVC shape_fit_ {shape_fit!r} is not (samples, {n})")
    if scalars["n_features_in_"] != n or scalars["kernel"] not in KERNELS or scalars["_sparse"] \
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


def platt_proba(decision: np.ndarray, platt: np.ndarray) -> np.ndarray:
    """Class probabilities from decision values through the per-class Platt sigmoids
    p = 1 / (1 + exp(a f + b)), normalised (two classes: one sigmoid)."""
    if platt.shape[0] == 1:
        a, b = platt[0]
        p = _sigmoid(-(a * decision + b))
        return np.column_stack([1.0 - p, p])
    p = _sigmoid(-(platt[:, 0] * decision + platt[:, 1]))
    total = p.sum(axis=1, keepdims=True)
    uniform = np.full_like(p, 1.0 / p.shape[1])
    return np.divide(p, total, out=uniform, where=total > 0)


def _sigmoid(z: np.ndarray) -> np.ndarray:
    """1 / (1 + exp(-z)) without overflow (scipy's expit, whose import is not needed here)."""
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(z, dtype=float)))


class SVMVote:
    """A fitted svm, read from a model file: ``predict`` and ``predict_proba`` only, computed
    in numpy from the SVC's support vectors, dual coefficients and intercepts."""

    def __init__(self, state: dict, arrays: dict[str, np.ndarray]) -> None:
        st = check_state(state, arrays, for_libsvm=False)
        self._state, self._arrays = state, dict(arrays)
        self.params = st.params
        self.classes_ = st.classes
        self.n_features_in_ = st.n_features
        self.mean_, self.scale_, self.platt_ = st.mean, st.scale, st.platt
        svc, sv = st.svc_scalars, st.svc_arrays
        self._kernel, self._gamma = svc["kernel"], float(svc["_gamma"])
        self._coef0, self._degree = float(svc["coef0"]), int(svc["degree"])
        self._ovr = svc["decision_function_shape"] == "ovr"
        self._vectors = sv["support_vectors_"]
        self._dual = sv["_dual_coef_"]
        self._intercept = sv["_intercept_"]
        self._starts = np.concatenate([[0], np.cumsum(sv["_n_support"])])

    @classmethod
    def from_state(cls, state: dict, arrays: dict[str, np.ndarray]) -> SVMVote:
        return cls(state, arrays)

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """The state it was loaded from (a model re-saved as it is, ``adapt``'s default way)."""
        return self._state, dict(self._arrays)

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        return dict(self.params)

    def _kernel_values(self, Z: np.ndarray) -> np.ndarray:
        sv, g = self._vectors, self._gamma
        if self._kernel == "rbf":
            d2 = (Z**2).sum(axis=1)[:, None] - 2.0 * Z @ sv.T + (sv**2).sum(axis=1)[None, :]
            return np.exp(-g * np.maximum(d2, 0.0))
        dot = Z @ sv.T
        if self._kernel == "linear":
            return dot
        if self._kernel == "poly":
            return (g * dot + self._coef0) ** self._degree
        return np.tanh(g * dot + self._coef0)

    def decision_function(self, Z: np.ndarray) -> np.ndarray:
        """scikit-learn's ``SVC.decision_function`` of standardised rows ``Z``."""
        K = self._kernel_values(Z)
        k, s = len(self.classes_), self._starts
        pairs = []
        for i in range(k):
            for j in range(i + 1, k):
                a, b = slice(s[i], s[i + 1]), slice(s[j], s[j + 1])
                pairs.append(K[:, a] @ self._dual[j - 1, a] + K[:, b] @ self._dual[i, b]
                             + self._intercept[len(pairs)])  # fmt: skip
        dec = np.column_stack(pairs)
        if k == 2:
            return -dec.ravel()  # scikit-learn's sign for two classes
        if not self._ovr:
            return dec
        votes = np.zeros((len(Z), k))
        confidence = np.zeros((len(Z), k))
        p = 0
        for i in range(k):
            for j in range(i + 1, k):
                d = dec[:, p]
                votes[:, i] += d >= 0
                votes[:, j] += d < 0
                confidence[:, i] += d
                confidence[:, j] -= d
                p += 1
        return votes + confidence / (3.0 * (np.abs(confidence) + 1.0))

    def predict_proba(self, X) -> np.ndarray:
        X = feature_rows(X, self.n_features_in_, "svm")
        return platt_proba(self.decision_function((X - self.mean_) / self.scale_), self.platt_)

    def predict(self, X) -> np.ndarray:
        return self.classes_[np.argmax(self.predict_proba(X), axis=1)]
