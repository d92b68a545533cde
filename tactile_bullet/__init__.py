"""tactile-bullet: in-hand tactile shape recognition with a simulated Shadow hand.

Plugins mark their hook implementations with :data:`hookimpl`::

    from tactile_bullet import hookimpl

    @hookimpl
    def register_classifiers(register):
        register("my-classifier", MyClassifier)
"""

__version__ = "0.1.0"

from .hookspecs import hookimpl  # noqa: E402  (after __version__: plugins.py imports it)

__all__ = ["__version__", "hookimpl"]
