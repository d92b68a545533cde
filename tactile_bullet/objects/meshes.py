"""Your own objects: any mesh file as a static object the hand grasps.

A mesh file (STL, OBJ, PLY, GLB/glTF, OFF, read by trimesh) becomes a :class:`MeshShape`, a
:class:`~tactile_bullet.objects.shapes.Shape` like the primitives, so ``simulate_grasp``, the
scene's placement and pose refusal, the theoretical signature and sweeps take it unchanged.
Processing, once per file content and options:

1. read, scale to metres (``unit`` x ``scale``), merge duplicate vertices, drop degenerate and
   duplicate faces;
2. simplify to :data:`TRIANGLE_BUDGET` triangles where larger (quadric decimation, the
   ``fast-simplification`` library): the surface the fingers touch loses well under a
   millimetre, and Bullet's contact queries stay as fast as on a primitive;
3. repair what trimesh can (fill small holes, consistent winding and outward normals);
4. find the main axis O-O' (principal axes of inertia, or the file's x, y or z axis when named),
   rotate it onto x and centre the object: O-O' through the centre of mass, the middle of the
   object's extent along O-O' at the origin, as the primitives are;
5. slice it across O-O' into the radius profile r(x) (:func:`radius_profile`).

The result is cached on disk (:func:`cache_dir`), keyed by the file's sha256 and the
processing options, so later loads, worker processes and re-simulations of saved records skip
steps 1-5. The object is static and collides as its exact (concave) triangle surface.

Equivalent radius of a section that is not a circle: the perimeter of its convex hull over
2 pi, i.e. its mean half-width (Cauchy). A finger wrapped on a convex section turns through
2 pi over the whole perimeter, so this is the circle that turns the fingers, on average, as
much as the section does (the thesis assumes each finger adapts to a circle, section 2.3.1);
for a circle it is the radius. Concavities and holes inside a section (a mug's inside, a
handle's eye) do not count: the fingers wrap the outside.

This module holds the pipeline from a user's file to a :class:`MeshShape` (sources, reading,
the order of the steps, the size checks); the geometry of each step lives in
:mod:`~tactile_bullet.objects.mesh_geometry` and the disk cache in
:mod:`~tactile_bullet.objects.mesh_cache`. A change to a step that changes what it produces
bumps ``PROCESSING_VERSION``, which keys the cache.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import UsageError
from .mesh_cache import CACHE_ARRAYS, CACHE_ENV, cache_dir, cache_path, read_cache, write_cache
from .mesh_formats import AXES, FORMATS, UNITS
from .mesh_geometry import (
    COLLISION_TRIANGLES,
    CONVEX_HULL_TRIANGLES,
    PROFILE_SAMPLES,
    SIMPLIFY_PASSES,
    SUPPORT_DIRECTIONS,
    collision_surface,
    main_axis,
    merge_vertices,
    radius_profile,
    simplify,
)
from .shapes import Shape, Surface

__all__ = [  # the names users import from here, the two stages' modules' included
    "CACHE_ARRAYS", "CACHE_ENV", "COLLISION_TRIANGLES", "CONVEX_HULL_TRIANGLES", "CONVEX_RATIO",
    "MAX_INPUT_TRIANGLES", "MAX_LENGTH", "MAX_RADIUS", "MIN_LENGTH", "MIN_RADIUS",
    "PROCESSING_VERSION", "PROFILE_SAMPLES", "SIMPLIFY_PASSES", "SUPPORT_DIRECTIONS",
    "TRIANGLE_BUDGET", "MeshInfo", "MeshShape", "MeshSource", "cache_dir", "cache_path",
    "check_name", "check_size", "count_triangles", "file_sha256", "forget_loaded", "gltf_buffer",
    "load_mesh", "load_source", "main_axis", "mesh_source", "radius_profile", "shape_of_record",
]  # fmt: skip

TRIANGLE_BUDGET = 20_000
"""Triangles kept for the analysis (r(x), axis, watertightness): a 200k-triangle object
decimated to it keeps its r(x) within 0.05 mm (benchmarks/bench_mesh.py); decimation time grows
with the input, not the budget."""

CONVEX_RATIO = 0.995
"""Volume / convex-hull volume above which a watertight object is treated as convex."""

MAX_INPUT_TRIANGLES = 2_000_000
"""The most triangles a mesh file may hold: reading and merging cost ~0.8 KB a triangle at
peak (a 1.3M-triangle STL: 1.1 GB, 16 s), so this bounds a load to ~1.7 GB. A binary STL's
count is read from its header and a PLY's or OFF's from theirs, before the file is parsed;
other formats are counted once parsed. Decimate a larger scan first (e.g. in MeshLab)."""

PROCESSING_VERSION = 3
"""Part of the cache key: bump when processing changes what it produces."""

MAX_RADIUS = 0.13
"""Largest distance (m) from O-O' allowed: the largest primitive grasped (the torus at its
largest sizes) reaches 0.125 m; past it the open hand cannot close around the object."""
MIN_RADIUS = 0.012
"""Smallest widest-section radius (m): thinner, the fingers curl to their limits before the
pads meet it (the smallest primitive section grasped is 20 mm; 12 mm still gives contacts)."""
MIN_LENGTH = 0.02
"""Shortest extent (m) along O-O': about one finger's width; shorter, at most one finger
meets it."""
MAX_LENGTH = 0.6
"""Longest extent (m) along O-O': the scene checks the object's clearance over +-0.3 m."""

NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]{0,63}$")
"""Object names are labels (classes): printable, no spaces, no path separators."""

PROCESSED = 0
"""How many meshes this process has processed (cache misses); tests read it."""

_MEMORY: dict[str, MeshShape] = {}
"""Processed meshes already loaded by this process, by cache key."""


# --- what identifies a processed mesh ------------------------------------------------------


@dataclass(frozen=True)
class MeshSource:
    """A mesh file and the options it is processed with: plain, picklable, JSON-able data that
    identifies one processed mesh (``key``) and travels in sweeps, tasks and records."""

    path: str
    sha256: str
    name: str
    unit: str = "m"
    scale: float = 1.0
    axis: str = "auto"
    budget: int = TRIANGLE_BUDGET

    @property
    def key(self) -> str:
        """The cache key: content hash + every option that changes the processed mesh."""
        options = f"{self.unit}|{self.scale!r}|{self.axis}|{self.budget}|v{PROCESSING_VERSION}"
        digest = hashlib.sha256(options.encode()).hexdigest()[:12]
        return f"{self.sha256[:32]}-{digest}"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> MeshSource:
        try:
            return cls(
                path=str(data["path"]),
                sha256=str(data["sha256"]),
                name=str(data["name"]),
                unit=str(data.get("unit", "m")),
                scale=float(data.get("scale", 1.0)),
                axis=str(data.get("axis", "auto")),
                budget=int(data.get("budget", TRIANGLE_BUDGET)),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise UsageError(f"not a valid mesh reference ({type(exc).__name__}: {exc})") from None

    def shape(self) -> MeshShape:
        """The processed mesh as a Shape (memory, then disk cache, then the file)."""
        return load_source(self)


def mesh_source(
    path: str | os.PathLike,
    unit: str = "m",
    scale: float = 1.0,
    axis: str = "auto",
    name: str | None = None,
    budget: int = TRIANGLE_BUDGET,
) -> MeshSource:
    """Check the options and hash the file (cheap: nothing is parsed yet)."""
    path = Path(path)
    if unit not in UNITS:
        raise UsageError(f"unit must be one of {', '.join(UNITS)}, got {unit!r}")
    if axis not in AXES:
        raise UsageError(f"axis must be one of {', '.join(AXES)}, got {axis!r}")
    scale = float(scale)
    if not math.isfinite(scale) or not 1e-3 <= scale <= 1e3:
        raise UsageError(f"scale must be a number in [0.001, 1000], got {scale:g}")
    if int(budget) < 500:
        raise UsageError(f"triangle budget must be at least 500, got {budget}")
    ext = _extension(path)
    if not path.exists():
        raise UsageError(f"mesh file {path} does not exist")
    if not path.is_file():
        raise UsageError(f"mesh file {path} is not a file")
    name = check_name(path.stem if name is None else name)
    _check_triangles(path.name, count_triangles(path, ext))
    return MeshSource(
        str(path.resolve()), file_sha256(path, ext), name, unit, scale, axis, int(budget)
    )


def _extension(path: Path) -> str:
    ext = path.suffix.lower().lstrip(".")
    if ext not in FORMATS:
        raise UsageError(
            f"{path.name}: unsupported mesh format {path.suffix or '(none)'!r} "
            f"(formats: {', '.join(FORMATS)})"
        )
    return ext


def check_name(name: str) -> str:
    """An object name usable as a class label, and not a registered shape's name."""
    if not NAME_PATTERN.match(name):
        raise UsageError(
            f"object name {name!r} must be 1-64 letters, digits or _.+- (it becomes a label)"
        )
    from ..plugins import shape_names

    if name in shape_names():
        raise UsageError(f"object name {name!r} is a registered shape's name: pass another name")
    return name


def file_sha256(path: Path, ext: str | None = None) -> str:
    """sha256 of the file, and of the buffers a .gltf names beside it (its geometry lives
    there: a changed .bin must not reuse a stale cache entry). Every file is checked as an
    input (a regular file within the mesh limit) and a buffer must lie inside the mesh's own
    folder, before anything is read: a glTF cannot make this read /dev/zero or /etc/passwd."""
    from ..files import input_path

    ext = ext or _extension(path)
    h = hashlib.sha256()
    data = _hash_file(input_path(path, "mesh file"), h, keep=ext == "gltf")
    if ext == "gltf":
        try:
            doc = json.loads(data)
            uris = [b.get("uri", "") for b in doc.get("buffers", []) if isinstance(b, dict)]
        except (ValueError, AttributeError):
            uris = []  # not glTF JSON: the loader says so
        for uri in uris:
            if isinstance(uri, str) and uri and not uri.startswith("data:"):
                _hash_file(gltf_buffer(path, uri), h, keep=False)
    return h.hexdigest()


def gltf_buffer(path: Path, uri: str) -> Path:
    """The file a glTF buffer ``uri`` names, by the rule every file an input references keeps
    (:func:`files.referenced_file`): inside the glTF's folder, a regular file of bounded size."""
    from urllib.parse import unquote

    from ..files import referenced_file

    return referenced_file(path.parent, unquote(uri), path.name, "mesh file", what="buffer")


def confined_resolver(path: Path):
    """The trimesh resolver a mesh is loaded with: every file the loader follows (an OBJ's
    ``mtllib`` and textures, a glTF's buffers) goes through :func:`files.referenced_file` as a
    glTF's buffers do, so a FIFO is never opened and nothing outside the mesh's folder or over
    the mesh limit is read (an OBJ's unreadable material is skipped: geometry needs none)."""
    from trimesh.resolvers import FilePathResolver

    from ..files import referenced_file

    class Confined(FilePathResolver):
        def get(self, name: str) -> bytes:
            target = referenced_file(path.parent, name.strip(), path.name, "mesh file",
                                     what="referenced file")  # fmt: skip
            try:
                return target.read_bytes()
            except OSError as exc:
                raise UsageError(f"cannot read {target}: {exc.strerror or exc}") from None

    return Confined(str(path.parent))


def _hash_file(path: Path, h, keep: bool) -> bytes:
    """Feed ``path`` to ``h`` in blocks (a large STL is never held twice); returns its bytes
    where ``keep`` (a .gltf's JSON, whose buffers are hashed next), else b""."""
    kept = []
    try:
        with open(path, "rb") as fh:
            while block := fh.read(1 << 20):
                h.update(block)
                if keep:
                    kept.append(block)
    except OSError as exc:
        raise UsageError(f"cannot read mesh file {path}: {exc.strerror or exc}") from None
    return b"".join(kept)


# --- the processed mesh --------------------------------------------------------------------


@dataclass(frozen=True)
class MeshInfo:
    """What processing found: for ``shape-info`` and ``grasp --json``."""

    triangles_in: int
    triangles: int
    """After simplification to the analysis budget."""
    collision_triangles: int
    """Of the surface the hand collides with (its convex hull's, for a convex object)."""
    convex: bool
    watertight: bool
    filled_holes: bool
    axis: tuple[float, float, float]
    """O-O' as a unit vector in the file's frame."""
    size: tuple[float, float, float]
    """Extent (m) along O-O' and the two other axes of the placed object (palm y, z)."""
    max_radius: float
    """Largest distance (m) of the surface from O-O'."""


@dataclass(frozen=True)
class MeshShape(Shape):
    """A processed mesh file as a Shape (no size parameters: its size is the file's).

    ``radius`` is the equivalent-radius profile (module docstring); ``palm_reach`` how far
    each section reaches toward the palm (+y), which places the object: a box's corner, not
    its equivalent circle, is what must clear the open hand."""

    source: MeshSource | None = None
    info: MeshInfo | None = None
    profile_x: np.ndarray = field(default_factory=lambda: np.zeros(0))
    profile_r: np.ndarray = field(default_factory=lambda: np.zeros(0))
    profile_reach: np.ndarray = field(default_factory=lambda: np.zeros(0))
    palm_reach: Callable[..., np.ndarray] | None = None

    @property
    def identity(self) -> dict[str, Any]:
        """What a GraspRecord stores to name this mesh and find it again."""
        return self.source.to_dict() if self.source is not None else {}


def _profile_fn(xs: np.ndarray, values: np.ndarray):
    def fn(x, **_params):
        return np.interp(np.asarray(x, float), xs, values, left=0.0, right=0.0)

    return fn


def _build_shape(source: MeshSource, info: MeshInfo, arrays: Mapping[str, np.ndarray]):
    """The Shape from the processed arrays (as cached): ``vertices``/``faces`` the analysis
    surface, ``collision_vertices``/``collision_faces`` what Bullet gets, ``profile_*``.
    Nothing here imports trimesh (~0.5 s of a command-line grasp of a cached mesh): the
    collision piece is a hull's points or a ``Surface``, and the trimesh of ``mesh()`` is
    made when something asks for it (a picture, a report)."""
    vertices, faces = arrays["vertices"], arrays["faces"]

    def mesh(**_params):
        import trimesh

        return trimesh.Trimesh(vertices, faces, process=False)

    if info.convex:  # a convex hull of these vertices, as the convex primitives
        piece: Any = np.asarray(arrays["collision_vertices"], float)
    else:  # the exact concave surface, a static triangle mesh
        piece = Surface(
            np.asarray(arrays["collision_vertices"], float),
            np.asarray(arrays["collision_faces"], np.int64),
        )
    px, pr, preach = arrays["profile_x"], arrays["profile_r"], arrays["profile_reach"]
    half = float(info.size[0]) / 2
    return MeshShape(
        name=source.name,
        params={},
        radius=_profile_fn(px, pr),
        mesh=mesh,
        pieces=lambda **_: [piece],
        doc=f"mesh {Path(source.path).name} (sha256 {source.sha256[:12]})",
        thesis=False,
        extent=lambda **_: half,
        source=source,
        info=info,
        profile_x=px,
        profile_r=pr,
        profile_reach=preach,
        palm_reach=_profile_fn(px, preach),
    )


def load_mesh(
    path: str | os.PathLike,
    unit: str = "m",
    scale: float = 1.0,
    axis: str = "auto",
    name: str | None = None,
    budget: int = TRIANGLE_BUDGET,
) -> MeshShape:
    """A mesh file as a graspable Shape: ``simulate_grasp(load_mesh("mug.stl", unit="mm"))``."""
    return load_source(mesh_source(path, unit, scale, axis, name, budget))


def load_source(source: MeshSource) -> MeshShape:
    """Memory, then the disk cache, then process the file (checking it is still the one
    hashed: a changed file is refused rather than simulated under the old identity)."""
    shape = _MEMORY.get(source.key)
    if shape is not None:
        return (
            replace(shape, name=source.name, source=source) if shape.name != source.name else shape
        )
    shape = _cached(source)
    if shape is None:
        path = Path(source.path)
        if not path.is_file():
            raise UsageError(
                f"mesh {source.name!r} ({path}) is missing and not in the cache {cache_dir()}"
            )
        if file_sha256(path) != source.sha256:
            raise UsageError(
                f"mesh file {path} changed since it was recorded (sha256 differs): "
                "re-run with the file as it is now"
            )
        shape, arrays = _process(source)
        write_cache(source, shape.info, arrays)
    _MEMORY[source.key] = shape
    return shape


def _cached(source: MeshSource) -> MeshShape | None:
    """The shape from the disk cache, or None where there is no sound entry."""
    entry = read_cache(source)
    if entry is None:
        return None
    info, arrays = entry
    try:
        info = MeshInfo(**{**info, "axis": tuple(info["axis"]), "size": tuple(info["size"])})
        return _build_shape(source, info, arrays)
    except Exception:  # noqa: BLE001 - any failure of a cache entry means: process again
        return None


def forget_loaded() -> None:
    """Drop this process's in-memory copies (the disk cache stays): tests, benchmarks."""
    _MEMORY.clear()


def _read_file(source: MeshSource):
    """The file as one trimesh, vertices scaled to metres, nothing merged yet."""
    import trimesh

    path = Path(source.path)
    _check_triangles(path.name, count_triangles(path, _extension(path)))
    try:
        loaded = trimesh.load(str(path), file_type=_extension(path), process=False,
                              resolver=confined_resolver(path))  # fmt: skip
    except Exception as exc:  # noqa: BLE001 - every parser raises its own kind
        detail = str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__
        raise UsageError(f"{path.name} is not a readable mesh ({detail})") from None
    if isinstance(loaded, trimesh.Scene):
        meshes = [g for g in loaded.dump() if isinstance(g, trimesh.Trimesh)]
        loaded = trimesh.util.concatenate(meshes) if meshes else None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise UsageError(f"{path.name} holds no triangles (empty, or a point cloud or path)")
    _check_triangles(path.name, len(loaded.faces))
    vertices = np.asarray(loaded.vertices, float) * (UNITS[source.unit] * source.scale)
    faces = np.asarray(loaded.faces, np.int64)
    if not np.all(np.isfinite(vertices)):
        raise UsageError(f"{path.name} has vertices that are not finite numbers")
    return vertices, faces


def count_triangles(path: Path, ext: str) -> int | None:
    """The triangle count a file's header declares (binary STL, PLY, OFF), read without
    parsing the file; None where the format has no such header."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return None
    if ext == "stl" and not head.lstrip().lower().startswith(b"solid"):
        size = path.stat().st_size
        return max((size - 84) // 50, int.from_bytes(head[80:84], "little"))
    if ext == "ply":
        found = re.search(rb"element\s+face\s+(\d+)", head)
        return int(found.group(1)) if found else None
    if ext == "off":
        lines = [ln for ln in head.splitlines() if ln.strip() and not ln.startswith(b"#")]
        counts = lines[1].split() if len(lines) > 1 else []
        return int(counts[1]) if len(counts) > 1 and counts[1].isdigit() else None
    return None


def _check_triangles(name: str, count: int | None) -> None:
    if count is not None and count > MAX_INPUT_TRIANGLES:
        raise UsageError(
            f"{name} holds {count:,} triangles, over the {MAX_INPUT_TRIANGLES:,} this reads "
            "(memory grows with them): decimate it first, e.g. in MeshLab or Blender"
        )


def _process(source: MeshSource) -> MeshShape:
    import trimesh

    global PROCESSED
    name = Path(source.path).name
    raw_v, raw_f = _read_file(source)
    triangles_in = len(raw_f)
    vertices, faces = merge_vertices(raw_v, raw_f)
    vertices, faces = simplify(vertices, faces, source.budget)
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.update_faces(mesh.unique_faces())  # duplicates, after decimation: 10x fewer to sort
    mesh.remove_unreferenced_vertices()
    filled = False
    if not mesh.is_watertight:
        filled = bool(mesh.fill_holes())
    mesh.fix_normals()
    watertight = bool(mesh.is_watertight)
    if source.axis == "auto" and not watertight:
        raise UsageError(
            f"{name} is not watertight (open edges remain after trimesh's repair), so its "
            "principal axes of inertia mean nothing: name its main axis with --axis x|y|z"
        )
    rotation, centre = main_axis(mesh, source.axis)
    transform = np.eye(4)
    transform[:3, :3] = rotation
    transform[:3, 3] = -rotation @ centre
    mesh.apply_transform(transform)
    lo, hi = mesh.bounds
    mesh.apply_translation([-(lo[0] + hi[0]) / 2, 0.0, 0.0])
    size = tuple(float(v) for v in mesh.extents)
    v = np.asarray(mesh.vertices)
    max_radius = float(np.hypot(v[:, 1], v[:, 2]).max())
    check_size(name, size, max_radius, source)
    px, pr, preach = radius_profile(mesh)
    if pr.max() < MIN_RADIUS:
        raise UsageError(
            f"{name} is too small for the hand: its widest section's equivalent radius is "
            f"{pr.max() * 1000:.1f} mm, {(MIN_RADIUS - pr.max()) * 1000:.1f} mm under the "
            f"{MIN_RADIUS * 1000:.0f} mm the fingers close on{_unit_hint(source, 'small')}"
        )
    convex = watertight and mesh.volume >= CONVEX_RATIO * mesh.convex_hull.volume
    collision = collision_surface(mesh, convex)
    info = MeshInfo(
        triangles_in=triangles_in,
        triangles=len(mesh.faces),
        collision_triangles=len(collision.faces),
        convex=bool(convex),
        watertight=watertight,
        filled_holes=filled,
        axis=tuple(float(c) for c in rotation[0]),
        size=size,
        max_radius=max_radius,
    )
    PROCESSED += 1
    arrays = {
        "vertices": np.asarray(mesh.vertices, float),
        "faces": np.asarray(mesh.faces, np.int64),
        "collision_vertices": np.asarray(collision.vertices, float),
        "collision_faces": np.asarray(collision.faces, np.int64),
        "profile_x": px,
        "profile_r": pr,
        "profile_reach": preach,
    }
    return _build_shape(source, info, arrays), arrays


def _unit_hint(source: MeshSource, which: str) -> str:
    if which == "large" and source.unit != "mm":
        return f" (is the file in millimetres? --unit mm; now --unit {source.unit})"
    if which == "small" and source.unit != "m":
        return f" (is the file in metres? --unit m; now --unit {source.unit})"
    return " (check --unit and --scale)"


def check_size(name: str, size, max_radius: float, source: MeshSource) -> None:
    """UsageError naming the limit and by how much, for an object the hand cannot grasp."""
    length = float(size[0])
    if max_radius > MAX_RADIUS:
        raise UsageError(
            f"{name} is too large for the hand: it reaches {max_radius:.3g} m from its axis, "
            f"{max_radius - MAX_RADIUS:.3g} m over the {MAX_RADIUS} m limit"
            f"{_unit_hint(source, 'large')}"
        )
    if length > MAX_LENGTH:
        raise UsageError(
            f"{name} is too long: {length:.3g} m along its axis, {length - MAX_LENGTH:.3g} m "
            f"over the {MAX_LENGTH} m limit{_unit_hint(source, 'large')}"
        )
    if length < MIN_LENGTH:
        raise UsageError(
            f"{name} is too small for the hand: {length * 1000:.1f} mm along its axis, "
            f"{(MIN_LENGTH - length) * 1000:.1f} mm under the {MIN_LENGTH * 1000:.0f} mm "
            f"limit{_unit_hint(source, 'small')}"
        )


# --- records and reports -------------------------------------------------------------------


def shape_of_record(record) -> MeshShape:
    """The mesh a record was grasped on (from the cache, or its file if unchanged), to
    re-simulate it; UsageError for a record of a primitive."""
    if not getattr(record, "mesh", None):
        raise UsageError(f"record of {record.shape!r} was not grasped on a mesh")
    return MeshSource.from_dict(record.mesh).shape()
