"""The plugin hooks: what a package may add to tactile-bullet.

Each hook receives a ``register(name, factory)`` callback instead of returning a list, so the
host decides naming and refuses duplicates with an error that names both plugins.
"""

from __future__ import annotations

import pluggy

PROJECT = "tactile_bullet"
"""pluggy project name, also the entry-point group plugins declare."""

hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def register_descriptors(register):
    """Register descriptors: ``register(name, factory)``, ``factory(**params)`` -> descriptor."""


@hookspec
def register_classifiers(register):
    """Register classifiers: ``register(name, factory)``, ``factory(**params)`` -> estimator."""


@hookspec
def register_shapes(register):
    """Register shapes: ``register(name, shape)`` with a ``shapes.Shape`` of that name."""


@hookspec
def register_engines(register):
    """Register physics engines: ``register(name, factory)``, ``factory(shape, params, pose,
    controller, *, gui=False, visual=False)`` -> a ``sim.engines.base.Engine``."""
