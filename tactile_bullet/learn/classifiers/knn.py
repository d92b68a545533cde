"""``knn``: k nearest neighbours on standardised features, the baseline to beat.

The search is a plain numpy distance matrix (in chunks) rather than scikit-learn's
KNeighborsClassifier: grasp data sets are small (hundreds to thousands of records), and
scikit-learn's search layers cost several milliseconds per single-grasp call, above the 5 ms
budget for identifying one grasp. It saves itself as numeric arrays (``to_state``), so a model
file of it loads without skops, whose import alone costs ~2 s (the default identifier is one).
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

CHUNK = 1024
"""Query rows per distance block: bounds memory at CHUNK x n_train floats."""


class KNNClassifier(ClassifierMixin, BaseEstimator):
    """Vote of the ``n_neighbors`` nearest training samples (Euclidean, standardised features).

    ``weights="distance"`` (default) weighs each neighbour by 1 / distance, and a query that
    coincides with training samples takes their labels only; ``"uniform"`` counts them
    equally. Fewer training samples than ``n_neighbors`` means all of them vote.
    """

    def __init__(self, n_neighbors=5, weights="distance"):
        self.n_neighbors = n_neighbors
        self.weights = weights

    def fit(self, X, y):
        X, y = validate_data(self, X, y)
        check_classification_targets(y)
        k = self.n_neighbors
        if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
            raise ValueError(f"knn n_neighbors must be an integer >= 1, got {k!r}")
        if self.weights not in ("distance", "uniform"):
            raise ValueError(f"knn weights must be 'distance' or 'uniform', got {self.weights!r}")
        self.classes_, self.y_index_ = np.unique(y, return_inverse=True)
        self.mean_ = X.mean(axis=0)
        scale = X.std(axis=0)
        self.scale_ = np.where(scale > 0, scale, 1.0)
        self.train_ = (X - self.mean_) / self.scale_
        return self

    def predict_proba(self, X) -> np.ndarray:
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        Z = (X - self.mean_) / self.scale_
        out = np.empty((len(Z), len(self.classes_)))
        for start in range(0, len(Z), CHUNK):
            out[start : start + CHUNK] = self._vote(Z[start : start + CHUNK])
        return out

    def _vote(self, Z: np.ndarray) -> np.ndarray:
        train = self.train_
        k = min(int(self.n_neighbors), len(train))
        d2 = (Z**2).sum(axis=1)[:, None] - 2.0 * Z @ train.T + (train**2).sum(axis=1)[None, :]
        np.maximum(d2, 0.0, out=d2)
        nearest = np.argpartition(d2, k - 1, axis=1)[:, :k]
        dist = np.sqrt(np.take_along_axis(d2, nearest, axis=1))
        if self.weights == "uniform":
            w = np.ones_like(dist)
        else:
            exact = dist <= 1e-12 * max(1.0, float(np.abs(train).max(initial=0.0)))
            w = np.where(exact.any(axis=1, keepdims=True), exact, 1.0 / np.maximum(dist, 1e-300))
        proba = np.zeros((len(Z), len(self.classes_)))
        rows = np.repeat(np.arange(len(Z)), k)
        np.add.at(proba, (rows, self.y_index_[nearest].ravel()), w.ravel())
        return proba / proba.sum(axis=1, keepdims=True)

    def predict(self, X) -> np.ndarray:
        proba = self.predict_proba(X)
        return self.classes_[np.argmax(proba, axis=1)]

    # -- saving (learn/models.py's state protocol) -------------------------------------------

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Parameters as JSON, the standardised training set as numeric arrays (no pickle)."""
        check_is_fitted(self)
        classes = np.asarray(self.classes_)
        if classes.dtype.kind not in "biuU":
            classes = classes.astype(str)
        arrays = {"classes": classes, "y_index": np.asarray(self.y_index_, dtype=np.int64),
                  "mean": self.mean_, "scale": self.scale_, "train": self.train_}  # fmt: skip
        state = {"params": {"n_neighbors": int(self.n_neighbors), "weights": self.weights},
                 "n_features_in": int(self.n_features_in_)}  # fmt: skip
        return state, arrays

    @classmethod
    def from_state(cls, state: dict, arrays: dict[str, np.ndarray]) -> KNNClassifier:
        """Rebuild a fitted estimator from ``to_state``'s output, checking every shape."""
        params = state["params"]
        est = cls(n_neighbors=params["n_neighbors"], weights=params["weights"])
        k = est.n_neighbors
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise ValueError(f"n_neighbors {k!r} is not a count")
        if est.weights not in ("distance", "uniform"):
            raise ValueError(f"weights {est.weights!r} is not distance or uniform")
        n = int(state["n_features_in"])
        est.classes_ = np.asarray(arrays["classes"])
        est.y_index_ = np.asarray(arrays["y_index"])
        est.mean_ = np.asarray(arrays["mean"], dtype=float)
        est.scale_ = np.asarray(arrays["scale"], dtype=float)
        est.train_ = np.asarray(arrays["train"], dtype=float)
        if est.mean_.shape != (n,) or est.scale_.shape != (n,) or est.train_.ndim != 2 \
                or est.train_.shape[1] != n or len(est.train_) < 1:  # fmt: skip
            raise ValueError("the training set does not match its feature count")
        if est.y_index_.shape != (len(est.train_),) or est.y_index_.dtype.kind not in "iu" or \
                est.y_index_.min() < 0 or est.y_index_.max() >= len(est.classes_):  # fmt: skip
            raise ValueError("the training labels do not match the classes")
        for name in ("mean_", "scale_", "train_"):
            if not np.all(np.isfinite(getattr(est, name))):
                raise ValueError(f"{name.rstrip('_')} holds non-numbers")
        if np.any(est.scale_ <= 0):
            raise ValueError("scale is not positive")
        est.n_features_in_ = n
        return est
