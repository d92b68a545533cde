"""``som``: a self-organizing map used as a classifier (thesis 2.4, SOM and U-matrix).

MiniSom trains the map on standardised features; each unit then holds the class
distribution of the training samples it wins, and a sample takes the distribution of its
best-matching unit (BMU). Units that won no training sample borrow the distribution of the
nearest unit that did (nearest in feature space), so every unit has an answer.

Only arrays are kept after ``fit`` (weights, hits, U-matrix), not the MiniSom object, so a
fitted map saves and loads without code.
"""

from __future__ import annotations

import numpy as np
from minisom import MiniSom
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils import check_random_state
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data


def umatrix(weights: np.ndarray) -> np.ndarray:
    """U-matrix (rows, cols): each unit's mean Euclidean distance to its 8 grid neighbours.

    High ridges separate clusters of the map; that is what the thesis' U-matrix figures show.
    """
    rows, cols, _ = weights.shape
    total = np.zeros((rows, cols))
    count = np.zeros((rows, cols))
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == dc == 0:
                continue
            r0, r1 = max(0, -dr), rows - max(0, dr)
            c0, c1 = max(0, -dc), cols - max(0, dc)
            here = weights[r0:r1, c0:c1]
            there = weights[r0 + dr : r1 + dr, c0 + dc : c1 + dc]
            total[r0:r1, c0:c1] += np.linalg.norm(here - there, axis=-1)
            count[r0:r1, c0:c1] += 1
    return np.divide(total, count, out=np.zeros_like(total), where=count > 0)


class SOMClassifier(ClassifierMixin, BaseEstimator):
    """Self-organizing map classifier.

    Parameters: ``rows`` x ``cols`` units; ``sigma`` the initial neighbourhood radius (units);
    ``learning_rate`` the initial step; ``epochs`` passes over the training set (in random
    order); ``random_state`` seeds initialisation and order.

    Fitted attributes: ``weights_`` (rows, cols, d) in standardised units, ``hits_`` (rows,
    cols, n_classes) training samples won per class, ``hit_map_`` (rows, cols) their total,
    ``unit_labels_`` (rows, cols) each unit's class, ``umatrix_`` (rows, cols) neighbour
    distances, ``mean_``/``scale_`` the standardisation.
    """

    def __init__(self, rows=8, cols=8, sigma=1.5, learning_rate=0.5, epochs=30, random_state=0):
        self.rows = rows
        self.cols = cols
        self.sigma = sigma
        self.learning_rate = learning_rate
        self.epochs = epochs
        self.random_state = random_state

    def _check_params(self) -> None:
        for name in ("rows", "cols", "epochs"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"som {name} must be an integer >= 1, got {value!r}")
        for name in ("sigma", "learning_rate"):
            value = getattr(self, name)
            if (
                not isinstance(value, int | float | np.number)
                or not np.isfinite(value)
                or value <= 0
            ):
                raise ValueError(f"som {name} must be a positive number, got {value!r}")

    def fit(self, X, y):
        X, y = validate_data(self, X, y)
        check_classification_targets(y)
        self._check_params()
        self.classes_, y_index = np.unique(y, return_inverse=True)
        self.mean_ = X.mean(axis=0)
        scale = X.std(axis=0)
        self.scale_ = np.where(scale > 0, scale, 1.0)
        Z = (X - self.mean_) / self.scale_
        seed = int(check_random_state(self.random_state).randint(np.iinfo(np.int32).max))
        som = MiniSom(
            int(self.rows),
            int(self.cols),
            Z.shape[1],
            sigma=float(self.sigma),
            learning_rate=float(self.learning_rate),
            random_seed=seed,
        )
        som.random_weights_init(Z)
        som.train(Z, int(self.epochs) * len(Z), random_order=True)
        self.weights_ = np.array(som.get_weights(), dtype=float)
        units = self.weights_.reshape(-1, Z.shape[1])
        hits = np.zeros((len(units), len(self.classes_)))
        np.add.at(hits, (self._bmu(Z), y_index), 1.0)
        won = hits.sum(axis=1)
        labelled = np.flatnonzero(won > 0)
        proba = np.zeros_like(hits)
        proba[labelled] = hits[labelled] / won[labelled, None]
        empty = np.flatnonzero(won == 0)
        if empty.size:
            gaps = np.linalg.norm(units[empty, None, :] - units[None, labelled, :], axis=-1)
            proba[empty] = proba[labelled[np.argmin(gaps, axis=1)]]
        self.unit_proba_ = proba
        shape = (int(self.rows), int(self.cols))
        self.hits_ = hits.reshape(*shape, len(self.classes_))
        self.hit_map_ = won.reshape(shape)
        self.unit_labels_ = self.classes_[np.argmax(proba, axis=1)].reshape(shape)
        self.umatrix_ = umatrix(self.weights_)
        return self

    def _bmu(self, Z: np.ndarray) -> np.ndarray:
        units = self.weights_.reshape(-1, self.weights_.shape[-1])
        d2 = (Z**2).sum(1)[:, None] - 2.0 * Z @ units.T + (units**2).sum(1)[None, :]
        return np.argmin(d2, axis=1)

    def bmu_coordinates(self, X) -> np.ndarray:
        """(n, 2) grid coordinates (row, col) of each sample's best-matching unit."""
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        flat = self._bmu((X - self.mean_) / self.scale_)
        return np.column_stack(np.unravel_index(flat, self.hit_map_.shape))

    def predict_proba(self, X) -> np.ndarray:
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        return self.unit_proba_[self._bmu((X - self.mean_) / self.scale_)]

    def predict(self, X) -> np.ndarray:
        proba = self.predict_proba(X)
        return self.classes_[np.argmax(proba, axis=1)]
