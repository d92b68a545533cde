"""``knn``: k nearest neighbours on standardised features, the baseline to beat."""

from __future__ import annotations

import numpy as np
from sklearn.neighbors import KNeighborsClassifier

from ._scaled import ScaledClassifier


class KNNClassifier(ScaledClassifier):
    """StandardScaler + k-nearest-neighbours vote (distance weighted by default)."""

    def __init__(self, n_neighbors=5, weights="distance"):
        self.n_neighbors = n_neighbors
        self.weights = weights

    def _model(self, y):
        k = self.n_neighbors
        if isinstance(k, int | np.integer) and not isinstance(k, bool):
            k = max(1, min(int(k), len(y)))  # a small training set still gets a vote
        return KNeighborsClassifier(n_neighbors=k, weights=self.weights)
