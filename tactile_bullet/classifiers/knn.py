"""``knn``: k nearest neighbours on standardised features, the baseline to beat."""

from __future__ import annotations

from sklearn.neighbors import KNeighborsClassifier

from ._scaled import ScaledClassifier


class KNNClassifier(ScaledClassifier):
    """StandardScaler + k-nearest-neighbours vote (distance weighted by default)."""

    def __init__(self, n_neighbors=5, weights="distance"):
        self.n_neighbors = n_neighbors
        self.weights = weights

    def _model(self):
        return KNeighborsClassifier(n_neighbors=self.n_neighbors, weights=self.weights)
