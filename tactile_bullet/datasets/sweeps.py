"""Sweeps: which grasps a dataset holds (shapes x sizes x positions x rotations).

A sweep is plain data, read from TOML or taken from a preset, and expands into a list of
:class:`GraspTask` with one seed each. Every dimension (a size parameter, an offset
coordinate, the rotation) is either a list of values or a ``{min, max}`` range, expanded as a
grid or drawn at random. The TOML format, the presets and the limits are described for users
in ``docs/sweeps.md``; mesh files join as ``[[objects]]`` tables (``objects/meshes.py``).

A ``[randomize]`` table draws the hand and physics per grasp (friction, thresT, closing speed,
phalanx lengths, joint reading offsets, J1/J2 coupling, contact stiffness, control rate), each
record keeping what it drew: ``datasets/randomize.py`` has its keys; the ``randomized`` preset
is the thesis preset with ``randomize.RANDOMIZED_TABLE``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import UsageError
from ..files import read_toml
from ..records import (
    MAX_OFFSET_M,
    MAX_ROTATION_DEG,
    ControllerSettings,
    Pose,
    controller_dict,
)
from .sweep_engines import check_engine, merge_engine, stamp_hand_model
from .sweep_values import numbers_or_range

if TYPE_CHECKING:
    from ..objects.meshes import MeshSource
    from ..objects.shapes import Shape
    from .randomize import Randomization

Dimension = tuple[float, ...] | dict[str, float]
"""A list of values, or {"min", "max"} (+ "steps" in grid mode)."""

MAX_GRASPS = 1_000_000
"""Most grasps one sweep may hold. Its tasks are built in memory before any simulation
(about 1 kB each), and a million grasps is already days of simulation on a few cores; a typo
such as ``samples = 1000000000`` or a grid of 1e12 points is refused before anything is
allocated (:meth:`Sweep.size`). Split larger collections into several datasets."""

SHAPE_KEYS = ("name", "params", "offset_x", "offset_y", "offset_z", "rotation_deg", "samples")
SWEEP_KEYS = ("name", "mode", "samples", "controller", "shapes", "objects", "randomize", "engine")
POSE_KEYS = ("offset_x", "offset_y", "offset_z", "rotation_deg", "samples")


@dataclass(frozen=True)
class GraspTask:
    """One grasp to simulate: everything ``simulate_grasp`` needs, plus its place in the sweep."""

    index: int
    shape: str
    params: dict[str, float]
    pose: Pose
    controller: ControllerSettings
    seed: int
    mesh: MeshSource | None = None
    """The mesh file an ``[[objects]]`` grasp is on (``shape`` is then its name)."""

    def target(self) -> str | Shape:
        """What ``simulate_grasp`` takes: the shape's name, or the processed mesh."""
        return self.shape if self.mesh is None else self.mesh.shape()


@dataclass(frozen=True)
class ShapeSweep:
    name: str
    params: dict[str, Dimension] = field(default_factory=dict)
    offset_x: Dimension = (0.0,)
    offset_y: Dimension = (0.0,)
    offset_z: Dimension = (0.0,)
    rotation_deg: Dimension = (0.0,)
    samples: int | None = None


@dataclass(frozen=True)
class ObjectSweep:
    """One mesh file of an ``[[objects]]`` table, with the poses to grasp it at."""

    source: MeshSource
    offset_x: Dimension = (0.0,)
    offset_y: Dimension = (0.0,)
    offset_z: Dimension = (0.0,)
    rotation_deg: Dimension = (0.0,)
    samples: int | None = None

    @property
    def name(self) -> str:
        return self.source.name


@dataclass(frozen=True)
class Sweep:
    name: str
    shapes: tuple[ShapeSweep, ...]
    mode: str = "grid"
    samples: int = 10
    controller: ControllerSettings = field(default_factory=ControllerSettings)
    objects: tuple[ObjectSweep, ...] = ()
    randomize: Randomization | None = None
    """The ``[randomize]`` table: hand and physics drawn per grasp (``datasets/randomize.py``)."""

    # --- construction -------------------------------------------------------------------

    @classmethod
    def from_dict(
        cls, data: Mapping[str, Any], source: str = "sweep", base: Path | None = None
    ) -> Sweep:
        """Validate and build; every problem is a UsageError naming the key. ``base``: the
        folder relative mesh paths start from (the TOML's)."""
        _no_unknown(data, SWEEP_KEYS, source)
        mode = data.get("mode", "grid")
        if mode not in ("grid", "random"):
            raise UsageError(f"{source}: mode must be 'grid' or 'random', got {mode!r}")
        samples = _positive_int(data.get("samples", 10), f"{source}: samples")
        controller_data = merge_engine(data, data.get("controller", {}), source)
        known = {f.name for f in fields(ControllerSettings)}
        _no_unknown(controller_data, tuple(known), f"{source}: [controller]")
        try:
            controller = ControllerSettings(**controller_data)
        except (TypeError, ValueError) as exc:  # UsageError is a ValueError
            raise UsageError(f"{source}: [controller] {exc}") from None
        check_engine(controller, source)
        controller = stamp_hand_model(controller, source)
        randomize = None
        if "randomize" in data:
            from .randomize import Randomization

            randomize = Randomization.from_dict(
                data["randomize"], f"{source}: [randomize]", controller
            )
        shapes_data = data.get("shapes", [])
        objects_data = data.get("objects", [])
        if not isinstance(shapes_data, list) or not isinstance(objects_data, list):
            raise UsageError(f"{source}: [[shapes]] and [[objects]] must be arrays of tables")
        if not shapes_data and not objects_data:
            raise UsageError(f"{source}: needs at least one [[shapes]] or [[objects]] table")
        shapes = tuple(_shape_sweep(s, mode, f"{source}: shapes[{i}]")
                       for i, s in enumerate(shapes_data))  # fmt: skip
        objects = tuple(
            o
            for i, table in enumerate(objects_data)
            for o in _object_sweeps(table, mode, f"{source}: objects[{i}]", base)
        )
        if objects:
            from ..objects.mesh_sets import check_sources

            check_sources([o.source for o in objects])  # bad meshes fail before any grasp
        return cls(
            name=str(data.get("name", "sweep")),
            shapes=shapes,
            mode=mode,
            samples=samples,
            controller=controller,
            objects=objects,
            randomize=randomize,
        )

    @classmethod
    def from_toml(cls, path: str | Path) -> Sweep:
        path = Path(path)
        data = read_toml(path, "config file")
        return cls.from_dict(data, source=str(path), base=path.parent)

    def to_dict(self) -> dict[str, Any]:
        """JSON/TOML-ready form, stored in the dataset manifest (and compared on --resume)."""
        return {
            "name": self.name,
            "mode": self.mode,
            "samples": self.samples,
            "controller": controller_dict(self.controller),
            "shapes": [_shape_dict(s) for s in self.shapes],
        } | ({"objects": [_object_dict(o) for o in self.objects]} if self.objects else {}) | (
            {"randomize": self.randomize.to_dict()} if self.randomize is not None else {}
        )

    # --- expansion ----------------------------------------------------------------------

    def size(self) -> int:
        """How many grasps the sweep holds at most (before size combinations that make no
        solid are left out), computed from the dimensions without expanding them."""
        total = 0
        for sweep in self.shapes:
            if self.mode == "random":
                total += sweep.samples or self.samples
                continue
            n = 1
            for dim in (*sweep.params.values(), sweep.offset_x, sweep.offset_y,
                        sweep.offset_z, sweep.rotation_deg):  # fmt: skip
                n *= len(dim) if isinstance(dim, tuple) else int(dim["steps"])
            total += n
        for obj in self.objects:  # mesh objects count like shapes
            if self.mode == "random":
                total += obj.samples or self.samples
                continue
            n = 1
            for dim in (obj.offset_x, obj.offset_y, obj.offset_z, obj.rotation_deg):
                n *= len(dim) if isinstance(dim, tuple) else int(dim["steps"])
            total += n
        return total

    def tasks(self, seed: int = 0) -> list[GraspTask]:
        """Every grasp of the sweep, in a fixed order, each with its own seed derived from
        ``seed`` and its index (so any subset can be re-run and give the same records).
        A sweep over :data:`MAX_GRASPS`, or one that leaves a shape with no valid size, is
        refused before any work."""
        from ..sim.grasp import resolve_shape

        if self.size() > MAX_GRASPS:
            raise UsageError(
                f"sweep {self.name!r} holds {self.size():,} grasps, over the limit of "
                f"{MAX_GRASPS:,} per dataset: lower samples or steps, or split it"
            )
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0]))
        specs: list[tuple[str, dict[str, float], Pose, MeshSource | None]] = []
        for sweep in self.shapes:
            shape = resolve_shape(sweep.name)
            dims: dict[str, Dimension] = {}
            for key, spec in shape.params.items():
                if key in sweep.params:
                    dims[f"p:{key}"] = sweep.params[key]
                elif self.mode == "grid":
                    dims[f"p:{key}"] = (spec.default,)
                else:
                    dims[f"p:{key}"] = {"min": spec.min, "max": spec.max}
            for key in ("offset_x", "offset_y", "offset_z", "rotation_deg"):
                dims[key] = getattr(sweep, key)
            if self.mode == "grid":
                rows = [r for r in _grid(dims) if geometry_ok(shape.name, _sizes(r))]
            else:
                rows = _random(dims, sweep.samples or self.samples, rng, shape.name)
            if not rows:
                raise UsageError(
                    f"sweep {self.name!r}: no size combination of {shape.name} makes a valid "
                    "solid, so the sweep would simulate none of it"
                )
            for row in rows:
                params = _sizes(row)
                shape.resolve(params)  # out-of-range sizes are refused before any work
                pose = Pose(
                    (row["offset_x"], row["offset_y"], row["offset_z"]),
                    math.radians(row["rotation_deg"]),
                )
                specs.append((sweep.name, params, pose, None))
        for obj in self.objects:
            dims = {key: getattr(obj, key) for key in POSE_KEYS[:4]}
            if self.mode == "grid":
                rows = _grid(dims)
            else:
                rows = _random(dims, obj.samples or self.samples, rng, obj.name)
            for row in rows:
                pose = Pose(
                    (row["offset_x"], row["offset_y"], row["offset_z"]),
                    math.radians(row["rotation_deg"]),
                )
                specs.append((obj.name, {}, pose, obj.source))
        seeds = np.random.SeedSequence(int(seed)).generate_state(len(specs), dtype=np.uint32)
        from .randomize import draw_for_task

        ctl = self.controller
        return [
            GraspTask(i, name, params, pose, draw_for_task(self.randomize, ctl, int(s)), int(s),
                      mesh)  # fmt: skip
            for i, ((name, params, pose, mesh), s) in enumerate(zip(specs, seeds, strict=True))
        ]


def geometry_ok(shape: str, params: Mapping[str, float]) -> bool:
    """False for size combinations that make no such solid (a torus whose tube closes its
    hole, a hyperboloid whose ends are narrower than its waist): a grid over independent
    ranges produces some, and they are left out of the sweep rather than failing it."""
    from ..objects.shapes import check_consistent

    try:
        check_consistent(shape, params)
    except UsageError:
        return False
    return True


# --- presets --------------------------------------------------------------------------------


def _linspace(lo: float, hi: float, n: int) -> tuple[float, ...]:
    return tuple(round(float(v), 5) for v in np.linspace(lo, hi, n))


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
            params[key] = _linspace(spec.min, spec.max, n) if n > 1 else (spec.default,)
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
            {k: _linspace(p.min, p.max, 3) for k, p in s.params.items() if p.unit == "m"},
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
            two = _linspace(spec.min + inset, spec.max - inset, 2)
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


# --- helpers --------------------------------------------------------------------------------


def _no_unknown(data: Mapping, allowed: Sequence[str], where: str) -> None:
    if not isinstance(data, Mapping):
        raise UsageError(f"{where} must be a table")
    unknown = sorted(set(data) - set(allowed))
    if unknown:
        raise UsageError(f"{where}: unknown key {unknown[0]!r} (keys: {', '.join(allowed)})")


def _positive_int(value: Any, what: str) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or value < 1:
        raise UsageError(f"{what} must be a positive integer, got {value!r}")
    return value


def _dimension(value: Any, mode: str, what: str) -> Dimension:
    dim = numbers_or_range(value, what, ("min", "max", "steps"))
    if isinstance(dim, dict) and mode == "grid":
        dim["steps"] = _positive_int(value.get("steps"), f"{what} steps (grid mode)")
    return dim


def _shape_sweep(data: Any, mode: str, where: str) -> ShapeSweep:
    _no_unknown(data, SHAPE_KEYS, where)
    from ..sim.grasp import resolve_shape

    if "name" not in data:
        raise UsageError(f"{where}: needs a shape name")
    shape = resolve_shape(str(data["name"]))
    params_data = data.get("params", {})
    _no_unknown(params_data, tuple(shape.params), f"{where} ({shape.name}) params")
    params = {}
    for key, value in params_data.items():
        dim = _dimension(value, mode, f"{where} params.{key}")
        spec = shape.params[key]
        lo, hi = (min(dim), max(dim)) if isinstance(dim, tuple) else (dim["min"], dim["max"])
        if lo < spec.min or hi > spec.max:
            raise UsageError(
                f"{where} params.{key} spans [{lo:g}, {hi:g}] {spec.unit}, outside the valid "
                f"range [{spec.min:g}, {spec.max:g}] {spec.unit} of {shape.name}"
            )
        params[key] = dim
    kwargs = {
        key: _dimension(data[key], mode, f"{where} {key}")
        for key in ("offset_x", "offset_y", "offset_z", "rotation_deg")
        if key in data
    }
    for key, dim in kwargs.items():
        # the CLI's bounds (records.Pose), checked here so the file's key is named
        limit, unit = (MAX_ROTATION_DEG, "deg") if key == "rotation_deg" else (MAX_OFFSET_M, "m")
        lo, hi = (min(dim), max(dim)) if isinstance(dim, tuple) else (dim["min"], dim["max"])
        if lo < -limit or hi > limit:
            raise UsageError(
                f"{where} {key} spans [{lo:g}, {hi:g}] {unit}, outside [-{limit:g}, {limit:g}]"
            )
    samples = data.get("samples")
    if samples is not None:
        samples = _positive_int(samples, f"{where} samples")
    return ShapeSweep(shape.name, params, samples=samples, **kwargs)


def _object_sweeps(data: Any, mode: str, where: str, base: Path | None) -> list[ObjectSweep]:
    from ..objects.mesh_sets import OBJECT_KEYS, sources_from_table

    _no_unknown(data, OBJECT_KEYS + POSE_KEYS, where)
    poses = {
        key: _dimension(data[key], mode, f"{where} {key}") for key in POSE_KEYS[:4] if key in data
    }
    samples = data.get("samples")
    if samples is not None:
        samples = _positive_int(samples, f"{where} samples")
    sources = sources_from_table(data, where, base)
    return [ObjectSweep(source, samples=samples, **poses) for source in sources]


def _object_dict(o: ObjectSweep) -> dict[str, Any]:
    """An object as the manifest stores it: absolute path and content hash, so a resumed or
    re-simulated dataset refuses a file that changed since."""
    src = o.source
    out: dict[str, Any] = {
        "file": src.path, "name": src.name, "sha256": src.sha256, "unit": src.unit,
        "scale": src.scale, "axis": src.axis, "budget": src.budget,
    }  # fmt: skip
    for key in POSE_KEYS[:4]:
        value = getattr(o, key)
        out[key] = list(value) if isinstance(value, tuple) else dict(value)
    if o.samples is not None:
        out["samples"] = o.samples
    return out


def _shape_dict(s: ShapeSweep) -> dict[str, Any]:
    def dim(d):
        return list(d) if isinstance(d, tuple) else dict(d)

    out = {"name": s.name, "params": {k: dim(v) for k, v in s.params.items()}}
    for key in ("offset_x", "offset_y", "offset_z", "rotation_deg"):
        out[key] = dim(getattr(s, key))
    if s.samples is not None:
        out["samples"] = s.samples
    return out


def _values(dim: Dimension) -> tuple[float, ...]:
    if isinstance(dim, tuple):
        return dim
    return _linspace(dim["min"], dim["max"], int(dim["steps"]))


def _grid(dims: Mapping[str, Dimension]) -> list[dict[str, float]]:
    keys = list(dims)
    axes = [_values(dims[k]) for k in keys]
    mesh = np.meshgrid(*axes, indexing="ij")
    flat = [m.ravel() for m in mesh]
    return [{k: float(col[i]) for k, col in zip(keys, flat, strict=True)}
            for i in range(flat[0].size)]  # fmt: skip


def _sizes(row: Mapping[str, float]) -> dict[str, float]:
    return {k[2:]: v for k, v in row.items() if k.startswith("p:")}


def _random(dims: Mapping[str, Dimension], n: int, rng: np.random.Generator, shape: str):
    """``n`` draws; a draw that makes no such solid is drawn again (up to 1000 tries)."""
    rows = []
    for _ in range(n):
        for _attempt in range(1000):
            row = {}
            for key, dim in dims.items():
                if isinstance(dim, tuple):
                    row[key] = float(dim[int(rng.integers(len(dim)))])
                else:
                    row[key] = float(rng.uniform(dim["min"], dim["max"]))
            if geometry_ok(shape, _sizes(row)):
                rows.append(row)
                break
        else:
            raise UsageError(f"{shape}: the size ranges given make no valid solid")
    return rows
