"""Presets: the named sweeps ``generate --preset`` runs (the thesis' sweep, its modified
shapes, chapter 3's and 4's sets, the randomised hands, the tour's and a smoke test), each at
full or small scale, with the sizes and times ``generate --help`` prints."""

from __future__ import annotations

from dataclasses import replace

from ..errors import UsageError
from ..records import ControllerSettings
from .sweeps import ShapeSweep, Sweep, linspace


def _thesis() -> Sweep:
    """The thesis' data collection (Table 2.1 in spirit): the five shapes, sizes across their
    valid ranges, the object moved +-10 mm along O-O' and along the fingers, and rotations
    0-25 deg in 5 deg steps for the torus, hyperboloid and cylinder."""
    from ..objects.shapes import BUILTIN_SHAPES

    rotations = tuple(float(a) for a in range(0, 30, 5))
    counts = {"sphere": {"radius": 7}, "cone": {"radius": 4, "length": 3}}
    shapes = []
    for shape in BUILTIN_SHAPES:
        if not shape.thesis:
            continue
        # 3 values per size parameter across its valid range; lengths stay at their default
        # except the cone's (its slope), and the sphere gets more radii (its only size).
        params = {}
        for key, spec in shape.params.items():
            n = counts.get(shape.name, {}).get(key, 1 if key == "length" else 3)
            params[key] = linspace(spec.min, spec.max, n) if n > 1 else (spec.default,)
        rotated = shape.name in ("torus", "hyperboloid", "cylinder")
        shapes.append(
            ShapeSweep(
                shape.name,
                params,
                offset_x=(-0.01, 0.0, 0.01),
                offset_z=(-0.01, 0.0, 0.01),
                rotation_deg=rotations if rotated else (0.0,),
            )
        )
    return Sweep("thesis", tuple(shapes))


def _modified() -> Sweep:
    """The modified shapes (ovoid, hexagonal pyramid) over their sizes and positions."""
    from ..objects.shapes import BUILTIN_SHAPES

    shapes = [
        ShapeSweep(
            s.name,
            {k: linspace(p.min, p.max, 3) for k, p in s.params.items() if p.unit == "m"},
            offset_x=(-0.01, 0.0, 0.01),
            offset_z=(-0.01, 0.0, 0.01),
        )
        for s in BUILTIN_SHAPES
        if not s.thesis
    ]
    return Sweep("modified", tuple(shapes))


def _tour(thesis: bool = True) -> Sweep:
    """The README tour's dataset: the five thesis shapes, each size parameter at two values
    inside its range (lengths at their default), the object at -8, 0 and +8 mm along O-O'
    (39 grasps, under a minute with 2 workers on 2 cores): the thesis preset's recipe, small.
    ``thesis=False``: the same recipe over the modified shapes (``modified --scale small``)."""
    from ..objects.shapes import BUILTIN_SHAPES

    shapes = []
    for shape in BUILTIN_SHAPES:
        if shape.thesis != thesis:
            continue
        params = {}
        for k, spec in shape.params.items():
            inset = 0.2 * (spec.max - spec.min)
            two = linspace(spec.min + inset, spec.max - inset, 2)
            params[k] = (spec.default,) if k == "length" else two
        shapes.append(ShapeSweep(shape.name, params, offset_x=(-0.008, 0.0, 0.008)))
    return Sweep("tour", tuple(shapes))


def _smoke() -> Sweep:
    """Four grasps: a quick end-to-end check of the whole pipeline."""
    return Sweep(
        "smoke",
        (
            ShapeSweep("cylinder", {"radius": (0.03, 0.045)}),
            ShapeSweep("sphere", {"radius": (0.04, 0.05)}),
        ),
    )


def _sequential() -> Sweep:
    """Chapter 4's classes: the five thesis shapes plus the cylinder and the cone turned 90 deg
    about the palm normal (axis along the fingers), 40 random sizes and positions each."""
    from ..objects.shapes import THESIS_SHAPES

    near = {"min": -0.005, "max": 0.005}
    shapes = [ShapeSweep(name, offset_x=near, offset_z=near) for name in THESIS_SHAPES]
    shapes += [
        ShapeSweep(name, offset_x=near, offset_z=near, rotation_deg=(90.0,))
        for name in ("cylinder", "cone")
    ]
    return Sweep("sequential", tuple(shapes), mode="random", samples=40)


def _temporal() -> Sweep:
    """Chapter 3's validation grasps (thesis Figs 3.4, 3.8): the five thesis shapes at the small
    end of their sizes, moved up to 30 mm sideways along O-O' so that the outer fingers often
    miss the object, 40 random draws each (200 grasps). The cone's radius keeps to the lower
    30% of its range (the others 40%) and within 25 mm of the centre: a wider cone 22-28 mm
    towards the little finger overlaps its metacarpal in the open hand, a grasp that cannot be
    made (tests/test_newcomer.py checks every draw is a grasp the open hand admits)."""
    from ..objects.shapes import BUILTIN_SHAPES

    shapes = []
    for shape in BUILTIN_SHAPES:
        if not shape.thesis:
            continue
        share = {("cone", "radius"): 0.3}
        small = {
            k: {"min": p.min,
                "max": round(p.min + share.get((shape.name, k), 0.4) * (p.max - p.min), 5)}
            for k, p in shape.params.items()
        }  # fmt: skip
        shapes.append(
            ShapeSweep(
                shape.name,
                small,
                offset_x={"min": -0.03, "max": 0.03} if shape.name != "cone" else
                {"min": -0.025, "max": 0.025},
                offset_z={"min": -0.005, "max": 0.005},
            )
        )
    return Sweep("temporal", tuple(shapes), mode="random", samples=40)


def _randomized(engine: str = "bullet") -> Sweep:
    """The thesis preset with the hand and physics drawn per grasp
    (``randomize.RANDOMIZED_TABLE``, as ``randomized_table`` fits it to ``engine``): training
    data for a hand that is not our simulator's."""
    from .randomize import Randomization, randomized_table

    thesis = _thesis()
    controller = ControllerSettings(engine=engine)
    table = Randomization.from_dict(randomized_table(engine), base=controller)
    return Sweep("randomized", thesis.shapes, controller=controller, randomize=table)


PRESETS = {
    "tour": _tour,
    "thesis": _thesis,
    "modified": _modified,
    "sequential": _sequential,
    "smoke": _smoke,
    "temporal": _temporal,
    "randomized": _randomized,
}


PRESET_HELP = {
    "tour": "the README tour's: the five thesis shapes, two sizes, three offsets",
    "thesis": "the thesis' sweep",
    "modified": "ovoid and hexagonal pyramid",
    "sequential": "chapter 4's seven classes",
    "temporal": "chapter 3's off-centre grasps",
    "randomized": "the thesis sweep, the hand drawn per grasp",
    "smoke": "a pipeline check",
}
"""What ``generate --help`` says of each preset beside its computed size and time."""

SECONDS_PER_GRASP = 0.32
"""A Bullet grasp's simulation on one worker (measured, docs/performance.md): the presets'
times in ``generate --help`` are their grasps x this / 2 workers (2 cores; MuJoCo is ~5x
faster, a loaded machine slower)."""


def preset_help(workers: int = 2) -> str:
    """One line per preset: name, grasps, what it is and about how long it takes."""
    from ..console import duration

    parts = []
    for name in PRESETS:
        sweep = PRESETS[name]()
        n = len(sweep.tasks(0))
        took = duration(n * SECONDS_PER_GRASP / workers)
        m = len(small(name, sweep).tasks(0))
        tour = f"; --scale small: {m:,}" if m != n else ""
        parts.append(f"{name} ({n:,} grasps, ~{took} on Bullet with --workers {workers}{tour}: "
                     f"{PRESET_HELP[name]})")  # fmt: skip
    return "; ".join(parts)


SCALES = ("full", "small")
"""``generate --scale``: a preset as declared (``full``) or tour-sized (``small``, see
:func:`small`)."""

SMALL_SAMPLES = {"temporal": 4, "sequential": 6}
"""Random draws per class of the random presets at ``--scale small``: temporal 5 x 4 = 20
grasps, sequential 7 x 6 = 42 (the sequential experiment holds a third of each class out and
needs at least 3 a class)."""


def small(name: str, sweep: Sweep) -> Sweep:
    """A preset at the README tour's size, the same recipe on fewer grasps: the grid presets
    over the tour's sizes and offsets (two sizes inside each range, -8/0/+8 mm along O-O'), the
    randomized preset's hand draws kept; the random presets with fewer draws per class
    (:data:`SMALL_SAMPLES`); ``tour`` and ``smoke`` are small already."""
    if name in ("thesis", "randomized"):
        return replace(sweep, name=f"{sweep.name}-small", shapes=_tour().shapes)
    if name == "modified":
        return replace(sweep, name=f"{sweep.name}-small", shapes=_tour(thesis=False).shapes)
    if name in SMALL_SAMPLES:
        return replace(sweep, name=f"{sweep.name}-small", samples=SMALL_SAMPLES[name])
    return sweep


def preset(name: str, engine: str = "bullet", scale: str = "full") -> Sweep:
    """A built-in sweep; ``engine`` fits the ``randomized`` preset's table to the engine that
    will run it (no contact stiffness without a soft-contact knob, the tendon's spring where a
    tendon splits J0), which ``generate --engine`` then sets. ``scale="small"``: the preset at
    the tour's size (:func:`small`)."""
    if name not in PRESETS:
        raise UsageError(f"unknown preset {name!r} (presets: {', '.join(PRESETS)})")
    if scale not in SCALES:
        raise UsageError(f"unknown scale {scale!r} (scales: {', '.join(SCALES)})")
    sweep = _randomized(engine) if name == "randomized" else PRESETS[name]()
    return small(name, sweep) if scale == "small" else sweep


