"""Randomised grasps: a sweep's ``[randomize]`` table draws the hand and physics per grasp.

A model trained at one simulator's physics learns that simulator: on grasps of another engine
with an independently written hand (issue 19) learned methods fell to 34-68%. Domain
randomisation trains on many plausible hands instead, drawing per grasp the knobs a real hand
varies in. Each key is a list (one value drawn uniformly from it) or a ``{min, max}`` range
(drawn uniformly); a key left out keeps the sweep's ``[controller]`` value::

    [randomize]
    friction = { min = 0.5, max = 1.2 }          # Coulomb friction, hand and object
    thres_t = { min = 0.28, max = 0.42 }         # N m, Algorithm 1's stop threshold
    closing_speed = { min = 1.0, max = 1.9 }     # rad/s of the joint targets
    phalanx_scale = { min = 0.95, max = 1.05 }   # every phalanx's length factor
    joint_offset_deg = 3.0                       # each FCI joint's reading offset, +-3 deg
    coupling = ["j2-first", "equal-torque", "distal-first"]   # J1/J2 tendon (sim/coupling.py)
    contact_stiffness = [0, 3000, 10000, 30000]  # N/m; 0 is the engine's rigid contact
    control_rate = [240, 120]                    # Hz of Algorithm 1's ticks
    tendon_spring = { min = 0.0, max = 0.5 }     # N m/rad on J1, engines with a real tendon
    servo_stiffness = [1, 2, 5, 10, 20]          # N m/rad, finger servos that are springs

Every drawn value lands in the grasp's ``ControllerSettings``, so each record says which hand
made it (fields at their defaults are left out of the saved form: records of sweeps without
the table stay byte-identical). The draw is seeded by the grasp's own seed, so a grasp re-run
alone (a resumed dataset, a subset) gets the same hand.

``control_rate`` sets ``control_every`` (physics steps per tick, at the ``[controller]``
timestep) and ``closing_speed`` sets ``delta`` for that rate: the two are independent knobs.
``engine = ["bullet", "mujoco"]`` draws the physics engine too (only installed engines; a
record's ``controller.engine`` says which made it). It is drawn last, so a table that adds it
keeps every other draw of each grasp as it was. ``contact_stiffness`` cannot be drawn with an
engine that has no such knob (:data:`SOFT_CONTACT_ENGINES`), nor ``tendon_spring`` or
``servo_stiffness`` with one that does not read them (``sim/engines/base.ENGINE_KNOBS``): an
engine that splits J0 by ``coupling`` has no tendon to put a spring on, and one whose motors
are constraints has no servo stiffness.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from ..errors import UsageError
from ..records import COUPLINGS, MAX_JOINT_OFFSET, OFFSET_JOINTS, ControllerSettings
from .sweep_values import numbers_or_range

Choice = tuple[float, ...] | dict[str, float]
"""A list of values, or {"min", "max"}."""

NUMERIC_KEYS = ("friction", "thres_t", "closing_speed", "phalanx_scale", "contact_stiffness",
                "control_rate", "tendon_spring", "servo_stiffness")  # fmt: skip
KEYS = (*NUMERIC_KEYS, "joint_offset_deg", "coupling", "engine")
DRAW_SALT = 0x52414E44
"""Mixed into each grasp's seed so the hand's draw is independent of anything else seeded by
it."""


@dataclass(frozen=True)
class Randomization:
    """What ``[randomize]`` draws (None: not drawn, the ``[controller]`` value stays)."""

    friction: Choice | None = None
    thres_t: Choice | None = None
    closing_speed: Choice | None = None
    phalanx_scale: Choice | None = None
    contact_stiffness: Choice | None = None
    control_rate: Choice | None = None
    tendon_spring: Choice | None = None
    servo_stiffness: Choice | None = None
    joint_offset_deg: float | None = None
    coupling: tuple[str, ...] | None = None
    engine: tuple[str, ...] | None = None

    @classmethod
    def from_dict(
        cls, data: Any, where: str = "[randomize]", base: ControllerSettings | None = None
    ) -> Randomization:
        """Validate a ``[randomize]`` table against the sweep's ``[controller]`` settings
        ``base``; every problem is a UsageError naming the key."""
        if not isinstance(data, Mapping):
            raise UsageError(f"{where} must be a table")
        unknown = sorted(set(data) - set(KEYS))
        if unknown:
            raise UsageError(f"{where}: unknown key {unknown[0]!r} (keys: {', '.join(KEYS)})")
        out: dict[str, Any] = {}
        for key in NUMERIC_KEYS:
            if key in data:
                out[key] = _choice(data[key], f"{where} {key}")
        if "joint_offset_deg" in data:
            v = data["joint_offset_deg"]
            limit = math.degrees(MAX_JOINT_OFFSET)
            if isinstance(v, bool) or not isinstance(v, int | float) or not 0 <= v <= limit:
                raise UsageError(
                    f"{where} joint_offset_deg must be a number from 0 to {limit:g} (each "
                    f"offset is drawn within +- it), got {v!r}"
                )
            out["joint_offset_deg"] = float(v)
        if "coupling" in data:
            names = data["coupling"]
            names = [names] if isinstance(names, str) else names
            if not isinstance(names, list) or not names or any(n not in COUPLINGS for n in names):
                raise UsageError(
                    f"{where} coupling must be a non-empty list of {', '.join(COUPLINGS)}, "
                    f"got {data['coupling']!r}"
                )
            out["coupling"] = tuple(names)
        if "engine" in data:
            out["engine"] = _engines(data["engine"], where)
            soft = out.get("contact_stiffness")
            rigid_only = [e for e in out["engine"] if e not in SOFT_CONTACT_ENGINES]
            fixed = base.contact_stiffness if base is not None else 0.0
            stiff = _extreme(soft, max) if soft is not None else fixed
            if rigid_only and stiff > 0:
                raise UsageError(
                    f"{where} contact_stiffness cannot be used with engine {rigid_only[0]!r}, "
                    f"which has no soft-contact knob (only {', '.join(SOFT_CONTACT_ENGINES)})"
                )
            if base is not None and base.hand_model is not None and out["engine"] != ("mujoco",):
                raise UsageError(f"{where} engine: a [controller] hand_model is the mujoco "
                                 "engine's only, so no other engine can be drawn with it")
        from ..sim.engines.base import ENGINE_KNOBS

        engines = out.get("engine") or ((base or ControllerSettings()).engine,)
        if "coupling" in out and out["coupling"] != ("j2-first",):
            # drawn with engines that read it, it goes to them only (Randomization._apply)
            if all(engine_reads(e, "tendon") for e in engines):
                raise UsageError(
                    f"{where} coupling cannot be drawn with engine {engines[0]!r}, whose tendon "
                    "splits J0 by its physics (draw tendon_spring)"
                )
        for name, (attr, needs) in ENGINE_KNOBS.items():
            if name in out:
                lacking = [e for e in engines if not engine_reads(e, attr)]
                if lacking:
                    raise UsageError(f"{where} {name} cannot be used with engine "
                                     f"{lacking[0]!r}, which lacks {needs}")  # fmt: skip
        result = cls(**out)
        result.draw(base or ControllerSettings(), np.random.default_rng(0), check=True)
        return result

    def to_dict(self) -> dict[str, Any]:
        """The table as the manifest stores it (keys drawn only)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if value is not None:
                out[f.name] = list(value) if isinstance(value, tuple) else value
        return out

    def draw(
        self, base: ControllerSettings, rng: np.random.Generator, check: bool = False
    ) -> ControllerSettings:
        """One grasp's settings: ``base`` with every drawn knob replaced. Draws happen in a
        fixed order, one per key whether or not others are set. With ``check`` every
        combination of the keys' extremes is tried, so a table that can draw invalid settings
        (a fast closing speed at a slow control rate: too large a step) fails on reading.
        """
        if check:
            for picks in itertools.product((min, max), repeat=len(NUMERIC_KEYS)):
                ends = {k: _extreme(getattr(self, k), pick)
                        for k, pick in zip(NUMERIC_KEYS, picks, strict=True)}  # fmt: skip
                self._apply(base, ends, 0.0, None, checking=True)
            return base
        values = {k: _draw(getattr(self, k), rng) for k in NUMERIC_KEYS}
        offsets = rng.uniform(-1.0, 1.0, len(OFFSET_JOINTS))
        coupling = None
        if self.coupling is not None:
            coupling = self.coupling[int(rng.integers(len(self.coupling)))]
        # The engine's draw comes last, so adding it keeps every earlier draw as it is.
        engine = None
        if self.engine is not None:
            engine = self.engine[int(rng.integers(len(self.engine)))]
        return self._apply(base, values, offsets, coupling, engine)

    def _apply(self, base, values, offsets, coupling, engine=None, checking: bool = False):
        changes: dict[str, Any] = {}
        for key in ("friction", "thres_t", "phalanx_scale", "contact_stiffness", "tendon_spring",
                    "servo_stiffness"):  # fmt: skip
            if values[key] is not None:
                changes[key] = round(float(values[key]), 6)
        every = base.control_every
        if values["control_rate"] is not None:
            rate, top = float(values["control_rate"]), 1.0 / base.timestep
            if not 0 < rate <= top * (1 + 1e-9):  # never clamped silently to one tick a step
                raise UsageError(
                    f"[randomize] control_rate must be above 0 Hz and at most one tick per "
                    f"physics step ({top:g} Hz at the [controller] timestep), got {rate:g}"
                )
            every = max(1, round(1.0 / (rate * base.timestep)))
            changes["control_every"] = every
        speed = values["closing_speed"]
        if speed is None and "control_every" in changes:
            speed = base.delta / (base.timestep * base.control_every)  # keep the speed
        if speed is not None:
            changes["delta"] = round(float(speed) * base.timestep * every, 6)
        if self.joint_offset_deg:
            bound = math.radians(self.joint_offset_deg)
            changes["joint_offsets"] = tuple(
                round(float(v), 6) for v in np.broadcast_to(offsets, len(OFFSET_JOINTS)) * bound
            )
        if engine is not None:
            changes["engine"] = engine
        # A drawn rule reaches an engine without a tendon only: from_dict refused a table whose
        # engines all have one, so only a drawn engine needs looking up (not every grasp's).
        if coupling is not None and (engine is None or not engine_reads(engine, "tendon")):
            changes["coupling"] = coupling
        try:
            return replace(base, **changes)
        except UsageError as exc:
            if checking:
                why = f"[randomize] gives invalid settings at a range end: {exc}"
                raise UsageError(why) from None
            raise


def draw_for_task(
    randomization: Randomization | None, base: ControllerSettings, seed: int
) -> ControllerSettings:
    """The settings of the grasp with ``seed``: ``base`` itself without a table."""
    if randomization is None:
        return base
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), DRAW_SALT]))
    return randomization.draw(base, rng)


RANDOMIZED_TABLE: dict[str, Any] = {
    "friction": {"min": 0.5, "max": 1.2},
    "thres_t": {"min": 0.28, "max": 0.42},
    "closing_speed": {"min": 1.0, "max": 1.9},
    "phalanx_scale": {"min": 0.95, "max": 1.05},
    "joint_offset_deg": 3.0,
    "coupling": list(COUPLINGS),
    "contact_stiffness": [0.0, 3000.0, 10000.0, 30000.0],
    "control_rate": [240.0, 120.0],
}
"""The ``randomized`` preset's table: friction and thresT +-20-50% around the defaults (0.8,
0.35 N m), closing speed 1.0-1.9 rad/s (default 1.44), phalanges +-5%, reading offsets within
+-3 deg (the sensor-noise protocol's headline bias), every coupling rule, rigid to soft
(3 kN/m) contacts, control at 240 or 120 Hz."""

SOFT_CONTACT_ENGINES: tuple[str, ...] = ("bullet",)
"""Engines with a ``contact_stiffness`` knob (MuJoCo's has no faithful counterpart yet and
refuses it, ``sim/engines/mujoco.py``)."""


TENDON_SPRING_RANGE: dict[str, float] = {"min": 0.0, "max": 0.5}
"""The distal return spring (N m/rad) drawn where a tendon splits J0 (MuJoCo's): the same span
of tendon behaviour as :data:`RANDOMIZED_TABLE`'s three coupling rules. On a 45 mm sphere our
MJCF closes J1 first at 0 (J2 0-11 deg, J1 80-91 deg), as Bullet's J2-first rule does at about
0.3 (J2 19-33 deg, J1 31-48 deg; Bullet 14-27 and 31-42), and J2 further first at 0.5."""


SERVO_STIFFNESS_CHOICES: tuple[float, ...] = (1.0, 2.0, 5.0, 10.0, 20.0)
"""The finger servos' stiffness (N m/rad) drawn where the engine's servos are springs
(MuJoCo's): from the MuJoCo Menagerie's Shadow hand (1) to our MJCF (20), log-spaced. Added
after measuring that hand (docs/independent_hand.md): its J3 closes 8 deg less than ours on a
sphere only because its servo (kp 1) yields when the tendon squeezes; at kp 20 its J3 equals
ours to the degree."""


def randomized_table(engine: str = "bullet") -> dict[str, Any]:
    """:data:`RANDOMIZED_TABLE` for grasps made with ``engine``: without the contact stiffness
    draw where the engine has no such knob (its own contact model stays); where a tendon
    splits J0 (``Engine.tendon``), the tendon's distal spring drawn instead of the coupling
    rule, which such an engine does not read; where its servos are springs, their stiffness
    drawn too; every other draw as it is."""
    table = dict(RANDOMIZED_TABLE)
    if engine not in SOFT_CONTACT_ENGINES:
        del table["contact_stiffness"]
    if engine_reads(engine, "tendon"):
        del table["coupling"]
        table["tendon_spring"] = dict(TENDON_SPRING_RANGE)
    if engine_reads(engine, "servo_gains"):
        table["servo_stiffness"] = list(SERVO_STIFFNESS_CHOICES)
    return table


def engine_reads(engine: str, attr: str) -> bool:
    """Whether ``engine``'s factory says it has ``attr`` (``tendon``, ``servo_gains``: the
    knobs of ``sim/engines/base.ENGINE_KNOBS`` it reads)."""
    from ..plugins import get_engine

    return bool(getattr(get_engine(engine), attr, False))


def _engines(value: Any, where: str) -> tuple[str, ...]:
    """A non-empty list of installed engine names, each once (the registry's UsageError names
    the installed ones, or how to install a missing one)."""
    from ..plugins import get_engine

    names = [value] if isinstance(value, str) else value
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise UsageError(f"{where} engine must be a non-empty list of engine names, got {value!r}")
    if len(set(names)) != len(names):
        raise UsageError(f"{where} engine names an engine twice: {value!r}")
    for name in names:
        try:
            get_engine(name)
        except UsageError as exc:
            raise UsageError(f"{where} engine: {exc}") from None
    return tuple(names)


def _choice(value: Any, what: str) -> Choice:
    return numbers_or_range(value, what)


def _draw(choice: Choice | None, rng: np.random.Generator) -> float | None:
    if choice is None:
        return None
    if isinstance(choice, tuple):
        return choice[int(rng.integers(len(choice)))]
    return float(rng.uniform(choice["min"], choice["max"]))


def _extreme(choice: Choice | None, pick) -> float | None:
    if choice is None:
        return None
    return pick(choice) if isinstance(choice, tuple) else choice[pick.__name__]
