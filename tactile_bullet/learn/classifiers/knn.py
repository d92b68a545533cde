"""``knn``: k nearest neighbours on standardised features, the baseline to beat.

The search is a plain numpy distance matrix in chunks (``neighbours.vote``) rather than
scikit-learn's KNeighborsClassifier: grasp data sets are small (hundreds to thousands of
records), and scikit-learn's search layers cost several milliseconds per single-grasp call,
above the 5 ms budget for identifying one grasp. It saves itself as numeric arrays
(``to_state``), and a saved model loads as a ``neighbours.NeighbourVote`` (the registry's
``fitted_form``), which needs neither skops nor scikit-learn, whose imports were most of a
command-line grasp's own time.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from ..neighbours import NeighbourVote, check_params, vote


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
        check_params(self.n_neighbors, self.weights)
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
        return vote(Z, self.train_, self.y_index_, len(self.classes_), self.n_neighbors,
                    self.weights)  # fmt: skip

    def predict(self, X) -> np.ndarray:
        proba = self.predict_proba(X)
        return self.classes_[np.argmax(proba, axis=1)]

    # -- saving (learn/models.py's state protocol) -------------------------------------------

    def fitted_vote(self) -> NeighbourVote:
        """The fitted vote alone, as a saved model loads it."""
        check_is_fitted(self)
        return NeighbourVote(self.classes_, self.y_index_, self.mean_, self.scale_, self.train_,
                             self.n_neighbors, self.weights)  # fmt: skip

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Parameters as JSON, the standardised training set as numeric arrays (no pickle)."""
        return self.fitted_vote().to_state()

    @classmethod
    def from_state(cls, state: dict, arrays: dict[str, np.ndarray]) -> KNNClassifier:
        """Rebuild a fitted estimator from ``to_state``'s output, checking every shape."""
        fitted = NeighbourVote.from_state(state, arrays)
        est = cls(n_neighbors=fitted.n_neighbors, weights=fitted.weights)
        for name in ("classes_", "y_index_", "mean_", "scale_", "train_", "n_features_in_"):
            setattr(est, name, getattr(fitted, name))
        return est
