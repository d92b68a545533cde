"""A fitted k-nearest-neighbour vote in numpy alone: what a saved ``knn`` model loads as.

The ``knn`` classifier (:mod:`~tactile_bullet.learn.classifiers.knn`) is a scikit-learn
estimator, and importing scikit-learn costs ~0.5 s: half of a command-line grasp's budget
beyond its simulation, for an answer that is a distance matrix and a vote. Fitting stays with
the estimator; a loaded model predicts through this class, whose :func:`vote` the estimator
also calls, so both answer alike by construction.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .rows import feature_rows

CHUNK = 1024
"""Query rows per distance block: bounds memory at CHUNK x n_train floats."""

WEIGHTS = ("distance", "uniform")


def check_params(n_neighbors: Any, weights: Any) -> None:
    """ValueError unless ``n_neighbors`` is a count and ``weights`` one of :data:`WEIGHTS`."""
    k = n_neighbors
    if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
        raise ValueError(f"knn n_neighbors must be an integer >= 1, got {k!r}")
    if weights not in WEIGHTS:
        raise ValueError(f"knn weights must be 'distance' or 'uniform', got {weights!r}")


def vote(
    Z: np.ndarray, train: np.ndarray, y_index: np.ndarray, n_classes: int,
    n_neighbors: int, weights: str,
) -> np.ndarray:  # fmt: skip
    """Class probabilities of standardised queries ``Z`` from the ``n_neighbors`` nearest
    standardised training rows (all of them when there are fewer). ``"distance"`` weighs a
    neighbour by 1 / distance, and a query that coincides with training rows takes their
    labels only; ``"uniform"`` counts them equally."""
    out = np.empty((len(Z), n_classes))
    k = min(int(n_neighbors), len(train))
    sq_train = (train**2).sum(axis=1)[None, :]
    tie = 1e-12 * max(1.0, float(np.abs(train).max(initial=0.0)))
    for start in range(0, len(Z), CHUNK):
        block = Z[start : start + CHUNK]
        d2 = (block**2).sum(axis=1)[:, None] - 2.0 * block @ train.T + sq_train
        np.maximum(d2, 0.0, out=d2)
        nearest = np.argpartition(d2, k - 1, axis=1)[:, :k]
        dist = np.sqrt(np.take_along_axis(d2, nearest, axis=1))
        if weights == "uniform":
            w = np.ones_like(dist)
        else:
            exact = dist <= tie
            w = np.where(exact.any(axis=1, keepdims=True), exact, 1.0 / np.maximum(dist, 1e-300))
        proba = np.zeros((len(block), n_classes))
        rows = np.repeat(np.arange(len(block)), k)
        np.add.at(proba, (rows, y_index[nearest].ravel()), w.ravel())
        out[start : start + len(block)] = proba / proba.sum(axis=1, keepdims=True)
    return out


class NeighbourVote:
    """A fitted knn, read from a model file: ``predict`` and ``predict_proba`` only.

    It keeps the estimator's fitted attributes under the same names (``classes_``,
    ``y_index_``, ``mean_``, ``scale_``, ``train_``, ``n_features_in_``), so code reading a
    knn's training grasps (``adapt``) reads either, and it saves itself as it was loaded.
    """

    def __init__(
        self, classes: np.ndarray, y_index: np.ndarray, mean: np.ndarray, scale: np.ndarray,
        train: np.ndarray, n_neighbors: int = 5, weights: str = "distance",
    ) -> None:  # fmt: skip
        check_params(n_neighbors, weights)
        self.n_neighbors = int(n_neighbors)
        self.weights = weights
        self.classes_ = np.asarray(classes)
        self.y_index_ = np.asarray(y_index)
        self.mean_ = np.asarray(mean, dtype=float)
        self.scale_ = np.asarray(scale, dtype=float)
        self.train_ = np.asarray(train, dtype=float)
        n = len(self.mean_)
        if self.mean_.shape != (n,) or self.scale_.shape != (n,) or self.train_.ndim != 2 \
                or self.train_.shape[1] != n or len(self.train_) < 1:  # fmt: skip
            raise ValueError("the training set does not match its feature count")
        y = self.y_index_
        if y.shape != (len(self.train_),) or y.dtype.kind not in "iu" or y.min() < 0 \
                or y.max() >= len(self.classes_):  # fmt: skip
            raise ValueError("the training labels do not match the classes")
        for name in ("mean_", "scale_", "train_"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise ValueError(f"{name.rstrip('_')} holds non-numbers")
        if np.any(self.scale_ <= 0):
            raise ValueError("scale is not positive")
        self.n_features_in_ = n

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        return {"n_neighbors": self.n_neighbors, "weights": self.weights}

    def predict_proba(self, X) -> np.ndarray:
        X = feature_rows(X, self.n_features_in_, "knn")
        Z = (X - self.mean_) / self.scale_
        return vote(Z, self.train_, self.y_index_, len(self.classes_), self.n_neighbors,
                    self.weights)  # fmt: skip

    def predict(self, X) -> np.ndarray:
        return self.classes_[np.argmax(self.predict_proba(X), axis=1)]

    # -- saving (learn/models.py's state protocol) -------------------------------------------

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Parameters as JSON, the standardised training set as numeric arrays (no pickle)."""
        classes = np.asarray(self.classes_)
        if classes.dtype.kind not in "biuU":
            classes = classes.astype(str)
        arrays = {"classes": classes, "y_index": np.asarray(self.y_index_, dtype=np.int64),
                  "mean": self.mean_, "scale": self.scale_, "train": self.train_}  # fmt: skip
        state = {"params": {"n_neighbors": int(self.n_neighbors), "weights": self.weights},
                 "n_features_in": int(self.n_features_in_)}  # fmt: skip
        return state, arrays

    @classmethod
    def from_state(cls, state: dict, arrays: dict[str, np.ndarray]) -> NeighbourVote:
        """Rebuild from ``to_state``'s output, checking every shape (ValueError if damaged)."""
        params = state.get("params") if isinstance(state, dict) else None
        if not isinstance(params, dict) or set(params) != {"n_neighbors", "weights"}:
            raise ValueError("a knn state holds n_neighbors and weights, this one does not")
        names = ("classes", "y_index", "mean", "scale", "train")
        if set(arrays) != set(names):
            raise ValueError(f"a knn state holds the arrays {', '.join(names)}, this one "
                             f"{', '.join(sorted(arrays)) or 'none'}")  # fmt: skip
        vote_ = cls(*(arrays[k] for k in names), params["n_neighbors"], params["weights"])
        if int(state["n_features_in"]) != vote_.n_features_in_:
            raise ValueError("the training set does not match its feature count")
        return vote_
