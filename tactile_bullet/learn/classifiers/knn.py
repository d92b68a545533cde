"""``knn``: k nearest neighbours on standardised features, the baseline to beat.

The search is a plain numpy distance matrix (in chunks) rather than scikit-learn's
KNeighborsClassifier: grasp data sets are small (hundreds to thousands of records), and
scikit-learn's search layers cost several milliseconds per single-grasp call, above the 5 ms
budget for identifying one grasp.
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
