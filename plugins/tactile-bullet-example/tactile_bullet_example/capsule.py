"""``capsule``: a cylinder with hemispherical ends, along O-O' like every tactile-bullet shape."""

from __future__ import annotations

import numpy as np

from tactile_bullet.objects.shapes import Param, Shape


def capsule_radius(x, radius=0.03, length=0.14):
    """r(x): constant along the body, a circle's profile over each end cap."""
    x = np.abs(np.asarray(x, dtype=float))
    body = length / 2 - radius
    cap = np.sqrt(np.clip(radius**2 - (x - body) ** 2, 0.0, None))
    return np.where(x <= body, radius, np.where(x <= length / 2, cap, 0.0))


def capsule(radius: float = 0.03, length: float = 0.14):
    """Capsule of ``radius`` (m) and overall ``length`` (m, caps included) along x, a
    ``trimesh.Trimesh`` (trimesh imported here, when a mesh is made: importing it takes a
    second, which every command that loads plugins would otherwise pay)."""
    import trimesh

    mesh = trimesh.creation.capsule(height=length - 2 * radius, radius=radius, count=[32, 32])
    mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    return mesh


def capsule_pieces(radius: float = 0.03, length: float = 0.14) -> list[np.ndarray]:
    """A capsule is convex: one piece."""
    return [np.asarray(capsule(radius, length).vertices)]


CAPSULE = Shape(
    "capsule",
    {
        "radius": Param(0.03, 0.02, 0.045, doc="body and cap radius"),
        "length": Param(0.14, 0.1, 0.18, doc="overall, caps included"),
    },
    capsule_radius,
    capsule,
    capsule_pieces,
    doc="cylinder with hemispherical ends (example plugin)",
    thesis=False,
    extent=lambda length, **_: length / 2,
)
