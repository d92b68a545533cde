"""What Algorithm 1 needs from a physics engine, and nothing more.

An engine holds the hand and one static object. The controller (``sim/grasp.py``) talks to it
in record columns (``hand.JOINT_NAMES`` order) and link names (``hand.FINGER_LINKS``), so the
same controller drives every engine and only stepping and reading differ. One :meth:`step`
advances the controller's tick (``ControllerSettings.timestep``); an engine may split it into
several physics steps of its own.

A third-party engine subclasses :class:`Engine` and registers a factory with the
``register_engines`` hook: ``register(name, factory)`` where
``factory(shape, params, pose, controller, *, gui=False, visual=False)`` returns the engine.
A factory whose engine has ``tendon = True`` says so too (``factory.tendon = True``, or the
class itself as the factory), and ``factory.servo_gains = True`` where its finger servos'
stiffness can be set: sweeps check the knobs of :data:`ENGINE_KNOBS` against them before any
grasp runs.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from pathlib import Path

import numpy as np

Contact = tuple[str, np.ndarray, np.ndarray, float]
"""(hand link name, position on the object, the object's outward normal, normal force), in the
palm frame (m, unit vector, N)."""


ENGINE_KNOBS: dict[str, tuple[str, str]] = {
    "tendon_spring": ("tendon", "a tendon splitting J0 by its physics"),
    "servo_stiffness": ("servo_gains", "finger servos of settable stiffness"),
}
"""``ControllerSettings`` fields only some engines read: field -> (the attribute of the engine's
factory that says it reads it, what such an engine has)."""


def unread_knob(controller, factory) -> str | None:
    """Why ``factory``'s engine cannot run ``controller`` (a knob of :data:`ENGINE_KNOBS` set
    that it does not read, or a coupling rule other than the default where a tendon splits J0
    by itself), in one line; None when it reads every knob set. A record must not say its grasp
    was made with a setting the engine ignored."""
    for name, (attr, needs) in ENGINE_KNOBS.items():
        if getattr(controller, name) > 0 and not getattr(factory, attr, False):
            return f"{name} needs an engine with {needs}, which {controller.engine} lacks"
    if controller.coupling != "j2-first" and getattr(factory, "tendon", False):
        return (
            f"coupling {controller.coupling} is a controller's rule for splitting J0; "
            f"{controller.engine}'s tendon splits it by its physics (vary tendon_spring)"
        )
    return None


class Engine(ABC):
    """The hand (fixed palm, the wrist welded) and one static object in one physics world.

    Attributes set by every engine: ``name``; ``columns`` the record columns of the joints it
    moves; ``lower``/``upper``/``damping`` per record column (rad, N m s/rad; 0 for joints it
    does not have); ``tendon`` True when the engine couples J1 and J2 itself (one actuator on
    J0 = J1 + J2, as the real hand's tendon) and then only the sum of the J2 and J1 targets it
    is sent matters (otherwise ``ControllerSettings.coupling`` splits J0, ``sim/coupling.py``).
    """

    name: str = ""
    tendon: bool = False
    columns: list[int]
    lower: np.ndarray
    upper: np.ndarray
    damping: np.ndarray

    @abstractmethod
    def reset_joints(self, cols: Sequence[int], values: Sequence[float]) -> None:
        """Teleport joints (no dynamics, zero velocity)."""

    @abstractmethod
    def penetrations(self, margin: float = 0.0) -> list[tuple[str, float]]:
        """Hand links overlapping the object deeper than ``margin`` (m), with their (negative)
        signed distance."""

    @abstractmethod
    def set_targets(self, cols: Sequence[int], targets: Sequence[float],
                    forces: Sequence[float]) -> None:  # fmt: skip
        """Position targets (rad) and effort limits (N m) of the motors of ``cols``."""

    @abstractmethod
    def step(self) -> None:
        """Advance one controller tick."""

    @abstractmethod
    def read(self, cols: Sequence[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Joint positions (rad), velocities (rad/s) and motor efforts (N m) of ``cols``."""

    @abstractmethod
    def touching(self) -> set[str]:
        """Names of the hand links touching the object now."""

    @abstractmethod
    def contacts(self) -> list[Contact]:
        """The hand-object contacts now, in the palm frame."""

    @abstractmethod
    def sweep_clear_fraction(self, cols: Sequence[int], goal: np.ndarray,
                             finger: str) -> float:  # fmt: skip
        """The fraction of the straight joint-space sweep of ``cols`` from 0 to ``goal`` over
        which ``finger``'s links keep ``clearance`` from the object (collision queries only;
        the joints are left at 0)."""

    @abstractmethod
    def bare_step_rate(self, steps: int) -> float:
        """Controller ticks per second of the engine alone from its current state (no Python
        work between ticks): the ceiling any controller around it could reach."""

    @abstractmethod
    def snapshot(self, path: str | Path, size: int = 480) -> Path:
        """Render the scene to a PNG (two square views of ``size`` pixels side by side)."""

    @abstractmethod
    def close(self) -> None:
        """Free the world; the engine is unusable afterwards."""

    def __enter__(self) -> Engine:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

