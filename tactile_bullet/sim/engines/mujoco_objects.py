"""The object as MuJoCo geoms: native where MuJoCo has the primitive, convex pieces elsewhere.

MuJoCo collides a mesh as its convex hull, so a concave solid must arrive as several convex
pieces. The sphere and the cylinder are native geoms (exact); the cone and the modified shapes
one convex mesh each (their collision hulls, as the bullet engine's); the torus as sectors
around O-O' (each the hull of a bent piece of tube) and the hyperboloid as slabs along O-O'
(each the hull of two rims), so the hole and the waist stay; any other concave mesh (a user's
``--mesh``) as the hulls of its surface cut into slabs along O-O' and sectors around it.
A hull overfills the concave surface it spans; :func:`overfill` measures by how much
(docs/engines.md quotes it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ...objects import shapes as builtin

TORUS_SECTORS = 24
"""Sectors of the torus around O-O': the chord of a 15-degree arc of the tube's centre circle
sits 0.4 mm inside it at the default 48 mm major radius."""
HYPERBOLOID_SLABS = 12
"""Slabs of the hyperboloid along O-O'."""
MESH_CELLS = (8, 8)
"""(slabs along O-O', sectors around it) a concave user mesh is cut into."""
RING_POINTS = 24
"""Points on each circle a piece of a solid of revolution is the hull of."""

_Z_TO_X = (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0)
"""(w, x, y, z): turns MuJoCo's cylinder axis (z) onto the object's O-O' (x)."""


@dataclass(frozen=True)
class Geom:
    """One geom in the object's frame: ``kind`` 'sphere', 'cylinder' or 'mesh' (then
    ``vertices``, whose convex hull MuJoCo collides)."""

    kind: str
    size: tuple[float, ...] = ()
    vertices: np.ndarray | None = None
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)


def object_geoms(shape, params: Mapping[str, float]) -> list[Geom]:
    """The geoms of ``shape`` at ``params`` (see the module docstring)."""
    mesh_fn = getattr(shape, "mesh", None)
    if mesh_fn is builtin.sphere:
        return [Geom("sphere", (params["radius"],))]
    if mesh_fn is builtin.cylinder:
        return [Geom("cylinder", (params["radius"], params["length"] / 2), quat=_Z_TO_X)]
    if mesh_fn is builtin.torus:
        return [Geom("mesh", vertices=v) for v in torus_cells(**params)]
    if mesh_fn is builtin.hyperboloid:
        return [Geom("mesh", vertices=v) for v in revolved_slabs(shape, params, HYPERBOLOID_SLABS)]
    out = []
    for piece in shape.pieces(**params):
        if isinstance(piece, np.ndarray):
            out.append(Geom("mesh", vertices=np.asarray(piece, float)))
        else:  # a concave triangle mesh (a cached Surface is made a trimesh to be cut)
            if not hasattr(piece, "bounds"):
                import trimesh

                piece = trimesh.Trimesh(piece.vertices, piece.faces, process=False)
            out += [Geom("mesh", vertices=v) for v in mesh_cells(piece, *MESH_CELLS)]
    return out


def _ring(x: float, radius: float, angles: np.ndarray) -> np.ndarray:
    return np.column_stack([np.full(len(angles), x), radius * np.cos(angles),
                            radius * np.sin(angles)])  # fmt: skip


def torus_cells(major_radius: float, minor_radius: float,
                sectors: int = TORUS_SECTORS) -> list[np.ndarray]:  # fmt: skip
    """The torus around O-O' as ``sectors`` pieces: each the points of the tube's
    cross-sections at the sector's two ends and its middle."""
    theta = np.linspace(0.0, 2 * math.pi, RING_POINTS, endpoint=False)
    cells = []
    for k in range(sectors):
        points = []
        for phi in np.linspace(2 * math.pi * k / sectors, 2 * math.pi * (k + 1) / sectors, 3):
            radial = np.array([0.0, math.cos(phi), math.sin(phi)])
            centre = major_radius * radial
            circle = (np.outer(np.cos(theta), [1.0, 0.0, 0.0])
                      + np.outer(np.sin(theta), radial)) * minor_radius  # fmt: skip
            points.append(centre + circle)
        cells.append(np.vstack(points))
    return cells


def revolved_slabs(shape, params: Mapping[str, float], slabs: int) -> list[np.ndarray]:
    """A solid of revolution about O-O' as ``slabs`` pieces along it: each the hull of the
    rims at its two ends (exact where the radius is linear in x, overfilling where the
    profile curves inward between them)."""
    half = float(shape.extent(**params))
    xs = np.linspace(-half, half, slabs + 1)
    radii = shape.radius(xs, **params)
    angles = np.linspace(0.0, 2 * math.pi, RING_POINTS, endpoint=False)
    return [np.vstack([_ring(xs[i], radii[i], angles), _ring(xs[i + 1], radii[i + 1], angles)])
            for i in range(slabs)]  # fmt: skip


_CELL_CACHE: dict[tuple[int, int, int], tuple[object, list[np.ndarray]]] = {}


def mesh_cells(mesh, slabs: int, sectors: int) -> list[np.ndarray]:
    """A closed triangle mesh cut into slabs along x and sectors around x: the vertices of
    each cell's surface (whose hull is the hull of the cell's solid). Cached per mesh object:
    a mesh file's Shape hands out the same one each grasp."""
    key = (id(mesh), slabs, sectors)
    if key in _CELL_CACHE and _CELL_CACHE[key][0] is mesh:
        return _CELL_CACHE[key][1]
    from trimesh.intersections import slice_mesh_plane

    lo, hi = mesh.bounds[:, 0]
    cuts = np.linspace(lo, hi, slabs + 1)
    cells = []
    for i in range(slabs):
        slab = slice_mesh_plane(mesh, [1.0, 0.0, 0.0], [cuts[i], 0.0, 0.0])
        slab = slice_mesh_plane(slab, [-1.0, 0.0, 0.0], [cuts[i + 1], 0.0, 0.0])
        for k in range(sectors):
            cell = slab
            if sectors > 1:
                a0, a1 = 2 * math.pi * k / sectors, 2 * math.pi * (k + 1) / sectors
                cell = slice_mesh_plane(cell, [0.0, -math.sin(a0), math.cos(a0)], [0, 0, 0])
                cell = slice_mesh_plane(cell, [0.0, math.sin(a1), -math.cos(a1)], [0, 0, 0])
            if len(cell.vertices) >= 4 and np.ptp(cell.vertices, axis=0).min() > 1e-6:
                cells.append(np.asarray(cell.vertices, float))
    _CELL_CACHE[key] = (mesh, cells)
    return cells


def torus_depth(points: np.ndarray, major_radius: float, minor_radius: float) -> np.ndarray:
    """Exact distance (m) of points outside the torus around O-O' (<= 0 inside)."""
    rho = np.hypot(points[:, 1], points[:, 2])
    return np.hypot(rho - major_radius, points[:, 0]) - minor_radius


def revolved_depth(points: np.ndarray, shape, params: Mapping[str, float]) -> np.ndarray:
    """Radial excess (m) of points over the exact profile r(x) of a solid of revolution: an
    upper bound of their distance outside it (<= 0 inside)."""
    rho = np.hypot(points[:, 1], points[:, 2])
    return rho - shape.radius(points[:, 0], **params)


def overfill(cells: list[np.ndarray], depth, samples: int = 20000) -> tuple[float, float]:
    """How far the union of the cells' hulls reaches outside the exact solid (m): the largest
    and the mean of ``depth(points)`` over points sampled on the hulls' surfaces that lie
    outside it (``depth`` > 0)."""
    import trimesh

    outside = []
    for cell in cells:
        hull = trimesh.convex.convex_hull(cell)
        points = hull.sample(max(50, samples // len(cells)), seed=0)
        d = depth(np.asarray(points))
        outside.append(d[d > 0])
    found = np.concatenate(outside) if outside else np.zeros(0)
    if not len(found):
        return 0.0, 0.0
    return float(found.max()), float(found.mean())
