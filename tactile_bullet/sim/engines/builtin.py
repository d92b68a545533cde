"""Built-in plugin: the ``bullet`` and ``mujoco`` engines.

Factories import their engine's module only when a grasp asks for it, so listing plugins never
imports PyBullet or MuJoCo. ``mujoco`` is an optional extra: its factory's ``missing()`` says
how to install it, and ``plugins.get_engine`` turns that into a UsageError before any work.
A factory's ``tendon`` repeats its engine's ``Engine.tendon``, so a sweep's tendon knobs are
checked without building an engine.
"""

from __future__ import annotations

import importlib.util

from ...hookspecs import hookimpl

MUJOCO_INSTALL = "pip install 'tactile-bullet[mujoco]'"


def bullet(shape, params, pose, controller, *, gui=False, visual=False):
    """PyBullet (the project's first engine; records made before engines existed are its)."""
    from .bullet import BulletEngine

    return BulletEngine(shape, params, pose, controller, gui=gui, visual=visual)


def mujoco(shape, params, pose, controller, *, gui=False, visual=False):
    """MuJoCo, with the hand's J1/J2 coupled by a fixed tendon as on the real hand."""
    from .mujoco import MujocoEngine

    return MujocoEngine(shape, params, pose, controller, gui=gui, visual=visual)


def _mujoco_missing() -> str | None:
    if importlib.util.find_spec("mujoco") is None:
        return f"the mujoco engine needs the mujoco package: {MUJOCO_INSTALL}"
    return None


mujoco.missing = _mujoco_missing  # type: ignore[attr-defined]
mujoco.tendon = True  # type: ignore[attr-defined]  # read before any grasp (Engine.tendon)
mujoco.servo_gains = True  # type: ignore[attr-defined]  # ControllerSettings.servo_stiffness


@hookimpl
def register_engines(register):
    register("bullet", bullet)
    register("mujoco", mujoco)
