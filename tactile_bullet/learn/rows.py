"""The feature rows a predict-only model form reads (``fitted_form``: ``NeighbourVote``,
``SVMVote``), checked as scikit-learn's ``validate_data`` would check them for the estimator,
without importing scikit-learn."""

from __future__ import annotations

import numpy as np


def feature_rows(X, n_features: int, what: str) -> np.ndarray:
    """``X`` as a float (n, ``n_features``) array of finite numbers; ValueError otherwise."""
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != n_features:
        raise ValueError(f"X has shape {X.shape}; this {what} reads rows of {n_features} features")
    if not np.all(np.isfinite(X)):
        raise ValueError("X holds NaN or infinity")
    return X
