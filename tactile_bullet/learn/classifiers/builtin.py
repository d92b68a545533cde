"""Built-in plugin: registers ``svm``, ``knn``, ``som``, ``dtw-template``, ``shape-fit``
(training-free, on ``raw-joints``), ``tcn`` (on the ``time-series`` descriptor), ``extra-trees``,
``fusion`` (extra-trees on the time series x the shape fit, on ``time-series+robust-joints``)
and, when its module is present, ``neural-forest``. Factories import their estimator on first
use, so loading the registry does not import scikit-learn."""

from __future__ import annotations

import importlib.util

from ...hookspecs import hookimpl


def svm(**params):
    from .svm import SVMClassifier

    return SVMClassifier(**params)


def _svm_vote() -> type:
    from ..svm_state import SVMVote

    return SVMVote


svm.fitted_form = _svm_vote
"""A saved svm loads as an SVMVote: predicting needs no scikit-learn (plugins.fitted_form)."""


def knn(**params):
    from .knn import KNNClassifier

    return KNNClassifier(**params)


def _knn_vote() -> type:
    from ..neighbours import NeighbourVote

    return NeighbourVote


knn.fitted_form = _knn_vote
"""A saved knn loads as a NeighbourVote: predicting needs no scikit-learn (plugins.fitted_form)."""


def som(**params):
    from .som import SOMClassifier

    return SOMClassifier(**params)


def dtw_template(**params):
    from .dtw_template import DTWTemplateClassifier

    return DTWTemplateClassifier(**params)


def shape_fit(**params):
    from .shape_fit import ShapeFitClassifier

    return ShapeFitClassifier(**params)


def _shape_fit_vote() -> type:
    from ..shape_fit_vote import ShapeFitVote

    return ShapeFitVote


shape_fit.fitted_form = _shape_fit_vote
"""A saved shape-fit model loads as a ShapeFitVote: answering needs no scikit-learn."""


def extra_trees(**params):
    """scikit-learn's extra-trees, seeded (without a seed two trainings give two models): the
    core tree ensemble, so the methods that need one do not depend on a plugin's."""
    from sklearn.ensemble import ExtraTreesClassifier

    params.setdefault("n_estimators", 100)
    params.setdefault("random_state", 0)
    return ExtraTreesClassifier(**params)


def fusion(**params):
    from .fusion import FusionClassifier

    return FusionClassifier(**params)


def neural_forest(**params):
    from ..neural_forest import NeuralForestClassifier

    return NeuralForestClassifier(**params)


def tcn(**params):
    from .tcn import TCNClassifier

    return TCNClassifier(**params)


@hookimpl
def register_classifiers(register):
    register("svm", svm)
    register("knn", knn)
    register("som", som)
    register("dtw-template", dtw_template)
    register("tcn", tcn)
    register("shape-fit", shape_fit)
    register("extra-trees", extra_trees)
    register("fusion", fusion)
    if importlib.util.find_spec("tactile_bullet.learn.neural_forest") is not None:
        register("neural-forest", neural_forest)
