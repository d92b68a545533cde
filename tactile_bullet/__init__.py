"""tactile-bullet: in-hand tactile shape recognition with a simulated Shadow hand.

The package follows the data: ``objects/`` (what is grasped) -> ``sim/`` (the hand grasping
it, Algorithm 1) -> a :class:`~tactile_bullet.records.GraspRecord` -> ``perception/`` (the
signature and the other training-free readings) and ``learn/`` (descriptors, classifiers,
models) -> ``datasets/`` (many grasps on disk), ``realhand/`` (a real hand's recordings) ->
``experiments/`` (workflow, benchmark, reports). ``docs/api.md`` lists the public API.

The names users need are importable from here, each on first use so that ``import
tactile_bullet`` stays light (the CLI's start, plugins)::

    from tactile_bullet import simulate_grasp, workflow, Identifier, read_records, hookimpl

Plugins mark their hook implementations with :data:`hookimpl`::

    from tactile_bullet import hookimpl

    @hookimpl
    def register_classifiers(register):
        register("my-classifier", MyClassifier)
"""

__version__ = "0.1.0"

import importlib

from .hookspecs import hookimpl  # noqa: E402  (after __version__: plugins.py imports it)

_LAZY: dict[str, tuple[str, str | None]] = {
    "simulate_grasp": ("tactile_bullet.sim.grasp", "simulate_grasp"),
    "workflow": ("tactile_bullet.experiments.workflow", None),
    "Identifier": ("tactile_bullet.realhand.streaming", "Identifier"),
    "next_pose": ("tactile_bullet.experiments.exploration", "next_pose"),
    "Grasp": ("tactile_bullet.experiments.exploration", "Grasp"),
    "read_records": ("tactile_bullet.datasets.dataset", "read_records"),
    "load_dataset": ("tactile_bullet.datasets.arrays", "load_dataset"),
    "open_dataset": ("tactile_bullet.datasets.dataset", "open_dataset"),
    "load_record": ("tactile_bullet.records", "load_record"),
    "save_record": ("tactile_bullet.records", "save_record"),
    "GraspRecord": ("tactile_bullet.records", "GraspRecord"),
    "Pose": ("tactile_bullet.records", "Pose"),
    "ControllerSettings": ("tactile_bullet.records", "ControllerSettings"),
    "signature_of": ("tactile_bullet.perception.signature", "signature_of"),
    "load_mesh": ("tactile_bullet.objects.meshes", "load_mesh"),
    "UsageError": ("tactile_bullet.errors", "UsageError"),
}
"""Public name -> (module, attribute; None for the module itself), imported on first use."""

__all__ = ["__version__", "hookimpl", *_LAZY]


def __getattr__(name: str):
    """Resolve a public name on first use (PEP 562), so the package import stays light."""
    try:
        module, attribute = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'tactile_bullet' has no attribute {name!r}") from None
    value = importlib.import_module(module)
    if attribute is not None:
        value = getattr(value, attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
