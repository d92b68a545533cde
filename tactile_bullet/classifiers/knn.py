"""``knn``: k nearest neighbours on standardised features, the baseline to beat."""

from __future__ import annotations

import numpy as np
from sklearn.neighbors import KNeighborsClassifier

from ._scaled import ScaledClassifier


class KNNClassifier(ScaledClassifier):
    """StandardScaler + k-nearest-neighbours vote (distance weighted by default).

    ``algorithm`` defaults to a k-d tree: scikit-learn's brute-force search goes through a
    thread-pool layer that costs tens of milliseconds per call, far above one grasp's budget.
    """

    def __init__(self, n_neighbors=5, weights="distance", algorithm="kd_tree"):
        self.n_neighbors = n_neighbors
        self.weights = weights
        self.algorithm = algorithm

    def _model(self, y):
        k = self.n_neighbors
        if isinstance(k, int | np.integer) and not isinstance(k, bool):
            k = max(1, min(int(k), len(y)))  # a small training set still gets a vote
        return KNeighborsClassifier(n_neighbors=k, weights=self.weights, algorithm=self.algorithm)
