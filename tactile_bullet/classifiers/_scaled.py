"""A classifier that standardises its features, then hands them to a scikit-learn model."""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data


class ScaledClassifier(ClassifierMixin, BaseEstimator):
    """Base of ``knn`` (and of any such wrapper): StandardScaler then ``_model(y)``, with
    predictions consistent with the probabilities (``predict`` is the most probable class), so
    ``identify`` never reports a shape that is not its most probable one."""

    def _model(self, y: np.ndarray):
        """The final estimator, given the training labels (to size folds or neighbours)."""
        raise NotImplementedError

    def fit(self, X, y):
        X, y = validate_data(self, X, y)
        check_classification_targets(y)
        self.pipeline_ = Pipeline([("scale", StandardScaler()), ("model", self._model(y))])
        self.pipeline_.fit(X, y)
        self.classes_ = self.pipeline_.classes_
        return self

    def predict_proba(self, X) -> np.ndarray:
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        return self.pipeline_.predict_proba(X)

    def predict(self, X) -> np.ndarray:
        proba = self.predict_proba(X)
        return self.classes_[np.argmax(proba, axis=1)]
