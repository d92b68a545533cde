"""Example tactile-bullet plugin: one classifier, one descriptor, one shape.

tactile-bullet finds this module through the ``tactile_bullet`` entry point declared in
``setup.cfg`` and calls the hooks below with a ``register(name, factory)`` callback.
"""

from __future__ import annotations

from tactile_bullet import hookimpl

__version__ = "0.1.0"


def random_forest(**params):
    """A seeded random forest: without a seed, two trainings would give two models."""
    from .forest import ExampleForest

    params.setdefault("n_estimators", 100)
    params.setdefault("random_state", 0)
    return ExampleForest(**params)


@hookimpl
def register_classifiers(register):
    register("random-forest", random_forest)


@hookimpl
def register_descriptors(register):
    from .closure import FingerClosure

    register(FingerClosure.name, FingerClosure)


@hookimpl
def register_shapes(register):
    from .capsule import CAPSULE

    register(CAPSULE.name, CAPSULE)
