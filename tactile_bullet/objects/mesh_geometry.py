"""The geometry of a mesh, as :mod:`~tactile_bullet.objects.meshes` processes a user's file:
merge duplicate vertices, simplify to a triangle budget, find the main axis O-O', slice the
surface into the radius profile r(x), and the surface the hand collides with.

Each step is a function of arrays or a trimesh, with no state and no file: ``meshes`` runs
them in order on a file and caches what they produce (``mesh_cache``).
"""

from __future__ import annotations

import numpy as np

from ..errors import UsageError

COLLISION_TRIANGLES = 1_000
"""Triangles the hand collides with on a concave object (decimated further from the analysis
mesh). Bullet's cost per step grows with the triangles under the finger capsules: on a waisted
200k-triangle solid, 2,000 took 6.6 ms a step, as the hyperboloid primitive's 2,240 do, 1,000
took 4.7 (the cylinder's hull 3.1), with final joint angles within 0.7 deg of the 2,000's. The
chord error (edges of ~7 mm on a 12 cm object) is ~0.2 mm, under the 9 mm capsules' reach."""

CONVEX_HULL_TRIANGLES = 1_000
"""A convex object collides as its hull (exact for it, and Bullet's fastest path, as the
primitives do), taken around the analysis mesh decimated to this many triangles (~500
vertices, the primitives' hull size)."""

SIMPLIFY_PASSES = 4
"""Quadric decimation passes at most: one pass stops short of a large reduction (5M -> 20k
kept 133k triangles), a second from there reaches the budget."""

PROFILE_SAMPLES = 241
"""Cross-sections along O-O': 0.5 mm apart on a 12 cm object, 2.5 mm on the longest allowed."""

SUPPORT_DIRECTIONS = 64
"""Directions around O-O' at which each section's support function is sampled: on a 50 x 70
mm box section the mean over 64 directions is 0.03 mm under the exact 38.20 mm (256: 0.002 mm,
at 4x the time; on smooth sections the error is smaller still)."""


def merge_vertices(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge vertices closer than a millionth of the object's size (an STL's triangle soup
    becomes a connected surface) and drop faces that collapse. Quantised keys in one int64:
    several times faster than trimesh's own merge on a 200k-triangle STL."""
    lo = vertices.min(axis=0)
    extent = float((vertices.max(axis=0) - lo).max())
    if extent <= 0:
        raise UsageError("the mesh is degenerate: all its vertices are one point")
    q = np.rint((vertices - lo) * ((2**20 - 1) / extent)).astype(np.int64)
    keys = (q[:, 0] << 42) | (q[:, 1] << 21) | q[:, 2]
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    faces = inverse.reshape(-1)[faces]
    vertices = vertices[first]
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    faces = faces[area2 > 1e-12 * extent**2]  # merged corners, or collinear ones
    if len(faces) == 0:
        raise UsageError("the mesh is degenerate: every triangle has zero area")
    return vertices, faces


def simplify(vertices, faces, budget: int):
    """Decimate to at most ``budget`` triangles (a pass stops short of large reductions, so
    it is repeated from where it stopped; a surface that cannot be reduced is refused)."""
    import fast_simplification

    for _ in range(SIMPLIFY_PASSES):
        if len(faces) <= budget:
            return vertices, faces
        before = len(faces)
        v, f = fast_simplification.simplify(
            np.ascontiguousarray(vertices, float), np.ascontiguousarray(faces, np.int32),
            target_count=budget,
        )  # fmt: skip
        vertices, faces = np.asarray(v, float), np.asarray(f, np.int64)
        if len(faces) >= before:
            break
    if len(faces) > budget * 1.05:  # the library lands a few triangles either side
        raise UsageError(
            f"the mesh could not be simplified to {budget:,} triangles ({len(faces):,} remain): "
            "it is likely many disconnected pieces; merge or decimate it first"
        )
    return vertices, faces


def collision_surface(mesh, convex: bool):
    """What Bullet collides with: the convex hull of a coarser copy for a convex object, the
    surface decimated to COLLISION_TRIANGLES otherwise (both in the object's frame)."""
    import trimesh

    budget = CONVEX_HULL_TRIANGLES if convex else COLLISION_TRIANGLES
    v, f = simplify(np.asarray(mesh.vertices), np.asarray(mesh.faces), budget)
    coarse = trimesh.Trimesh(v, f, process=False)
    return coarse.convex_hull if convex else coarse


def main_axis(mesh, axis: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """(R, c): a rotation whose first row is O-O' in the file's frame (R maps file
    coordinates to the object's: O-O' -> x) and the point O-O' passes through.

    ``auto``: the principal axis of inertia whose moment stands apart from the other two (the
    symmetry axis of a solid of revolution, long or flat; the long axis of a box); when none
    does (a sphere), the axis of least inertia. The other two principal axes become z (the
    larger moment's) and y. The sign puts the object's heavier end toward -x, where the
    cone's base lies. A named axis maps the file's x, y or z onto O-O' (cyclically), through
    the centre of mass (of the surface, for an open mesh).
    """
    if axis in ("x", "y", "z"):
        k = "xyz".index(axis)
        rows = np.roll(np.eye(3), k, axis=1)  # row 0 = the named axis, then cyclic
        centre = mesh.center_mass if mesh.is_volume else mesh.centroid
        return rows, np.asarray(centre, float)
    moments = np.asarray(mesh.principal_inertia_components, float)
    vectors = np.asarray(mesh.principal_inertia_vectors, float)
    scale = max(float(moments.max()), 1e-300)
    apart = np.array(
        [min(abs(moments[i] - moments[j]) for j in range(3) if j != i) for i in range(3)]
    )
    i = int(np.argmax(apart)) if apart.max() > 0.02 * scale else int(np.argmin(moments))
    rest = [j for j in range(3) if j != i]
    k_z = max(rest, key=lambda j: moments[j])
    x_axis = vectors[i] / np.linalg.norm(vectors[i])
    z_axis = vectors[k_z] - x_axis * (vectors[k_z] @ x_axis)
    z_axis /= np.linalg.norm(z_axis)
    centre = np.asarray(mesh.center_mass, float)
    # heavier end toward -x: the third moment of the volume along the axis
    along = (np.asarray(mesh.triangles_center) - centre) @ x_axis
    weights = np.asarray(mesh.area_faces)
    lo_hi = np.ptp(along) / 2
    mid = (along.max() + along.min()) / 2
    if lo_hi > 0 and float(np.sum(weights * (along - mid))) > 0:
        x_axis, z_axis = -x_axis, z_axis
    y_axis = np.cross(z_axis, x_axis)
    return np.vstack([x_axis, y_axis, z_axis]), centre


def radius_profile(mesh, samples: int = PROFILE_SAMPLES):
    """(x, r, reach) along O-O' (the mesh's x axis), from cross-sections of the surface.

    r(x) is the section's equivalent radius: the perimeter of its convex hull / 2 pi (module
    docstring), computed as the mean of its support function h(theta) = max over the section
    of p . u(theta) (Cauchy's formula: the mean half-width), which needs no hull and runs for
    all sections at once. reach(x) = h(+y): how far it extends toward the palm, for placement.
    Sections are cut at ``samples`` evenly spaced planes between the object's ends; r is 0 at
    both ends, as the primitives' profiles are. A section's points are where the mesh's edges
    cross its plane (vectorised over all edges and planes).
    """
    v = np.asarray(mesh.vertices, float)
    edges = np.asarray(mesh.edges_unique)
    lo, hi = float(v[:, 0].min()), float(v[:, 0].max())
    xs = np.linspace(lo, hi, samples)
    a, b = v[edges[:, 0]], v[edges[:, 1]]
    swap = a[:, 0] > b[:, 0]
    a[swap], b[swap] = b[swap], a[swap].copy()
    # planes crossed by each edge: xs[first..last] within [a.x, b.x]
    first = np.searchsorted(xs, a[:, 0], side="left")
    last = np.searchsorted(xs, b[:, 0], side="right") - 1
    count = np.clip(last - first + 1, 0, None)
    count[b[:, 0] - a[:, 0] <= 0] = 0  # edges inside a plane: their vertices count below
    edge_of = np.repeat(np.arange(len(edges)), count)
    offsets = np.concatenate([[0], np.cumsum(count)[:-1]])
    plane = first[edge_of] + (np.arange(count.sum()) - np.repeat(offsets, count))
    ea, eb = a[edge_of], b[edge_of]
    t = (xs[plane] - ea[:, 0]) / (eb[:, 0] - ea[:, 0])
    points = ea[:, 1:] + t[:, None] * (eb[:, 1:] - ea[:, 1:])
    on = np.searchsorted(xs, v[:, 0])  # vertices lying exactly on a plane
    exact = (on < samples) & (xs[np.clip(on, 0, samples - 1)] == v[:, 0])
    plane = np.concatenate([plane, on[exact]])
    points = np.concatenate([points, v[exact][:, 1:]])
    order = np.argsort(plane, kind="stable")
    plane, points = plane[order], points[order]
    theta = np.linspace(0.0, 2 * np.pi, SUPPORT_DIRECTIONS, endpoint=False)
    u = np.stack([np.cos(theta), np.sin(theta)])  # theta = 0 is +y, toward the palm
    support = np.full((samples, SUPPORT_DIRECTIONS), -np.inf)
    bounds = np.searchsorted(plane, np.arange(samples + 1))
    k = 0
    while k < samples:  # blocks of whole planes, ~16k points each (n x 64 products)
        end = max(k + 1, int(np.searchsorted(bounds, bounds[k] + 16384, side="right")) - 1)
        end = min(end, samples)
        starts = bounds[k:end]
        full = starts < bounds[k + 1 : end + 1]  # planes with points
        if full.any():
            py, pz = points[bounds[k] : bounds[end]].T
            block = u[0][:, None] * py + u[1][:, None] * pz  # (directions, points)
            cuts = starts[full] - bounds[k]  # along contiguous rows: 10x faster
            support[k:end][full] = np.maximum.reduceat(block, cuts, axis=1).T
        k = end
    present = np.isfinite(support[:, 0])
    radius = np.where(present, support.mean(axis=1, where=present[:, None]), 0.0)
    reach = np.where(present, support[:, 0], 0.0)
    # reach also covers the surface between two planes: the vertices in each slab
    step = max(float(xs[1] - xs[0]), 1e-12)
    slab = np.clip(np.rint((v[:, 0] - lo) / step).astype(int), 0, samples - 1)
    np.maximum.at(reach, slab, v[:, 1])
    radius = np.clip(radius, 0.0, None)
    radius[0] = radius[-1] = 0.0
    return xs, radius, reach
