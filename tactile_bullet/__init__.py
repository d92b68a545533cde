"""tactile-bullet: in-hand tactile shape recognition with a simulated Shadow hand.

Plugins mark their hook implementations with :data:`hookimpl`::

    from tactile_bullet import hookimpl

    @hookimpl
    def register_classifiers(register):
        register("my-classifier", MyClassifier)

Live identification from a real hand's joint states: ``from tactile_bullet import Identifier``
(``streaming.py``).
"""

__version__ = "0.1.0"

from .hookspecs import hookimpl  # noqa: E402  (after __version__: plugins.py imports it)

__all__ = ["Identifier", "__version__", "hookimpl"]


def __getattr__(name: str):
    """``Identifier`` on first use: the package import stays light (no numpy models, no
    rosbags) for the CLI's start and for plugins."""
    if name == "Identifier":
        from .streaming import Identifier

        return Identifier
    raise AttributeError(f"module 'tactile_bullet' has no attribute {name!r}")
