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
from dataclasses import dataclass, field, fields
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


def linspace(lo: float, hi: float, n: int) -> tuple[float, ...]:
    return tuple(round(float(v), 5) for v in np.linspace(lo, hi, n))


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
    return linspace(dim["min"], dim["max"], int(dim["steps"]))


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
