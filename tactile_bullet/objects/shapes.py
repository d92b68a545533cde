"""The test shapes: one function per primitive, and a table of them.

Every shape is a solid whose main axis O-O' is the x axis of its own frame (the palm's x axis
once placed), centred on the origin. Each one gives three things:

- ``mesh(**params)``: a watertight trimesh for rendering and checks;
- ``radius(x, **params)``: the radius profile r(x) along O-O' (0 outside the solid), what a
  finger wrapping the cross-section at x adapts to (thesis eq. 2.3, theta = s / r);
- ``pieces(**params)``: the collision geometry for Bullet: convex vertex sets (hulls), or a
  ``Surface`` (vertices, faces) for an exact static triangle mesh. Convex shapes are one hull;
  the torus and the hyperboloid are triangle meshes, so the hole and the waist stay (never the
  convex hull of a concave solid). The built-in revolved ones are made without trimesh
  (``revolved_surface``), the same to the bit as their meshes.

Sizes are in metres. Valid ranges are where the object clears the open hand and the grasp
closes on it (both ends of every range were simulated; at the largest sphere and ovoid one
finger can miss). Where the signature identifies the shape is narrower: see
``docs/signature_invariance.md``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..errors import UsageError

if TYPE_CHECKING:
    import trimesh

SECTIONS = 48
"""Facets around the axis: a 0.2% radius error, below Bullet's collision margin here."""


class Surface(NamedTuple):
    """An exact (concave) triangle surface: what a shape hands Bullet as a static mesh."""

    vertices: np.ndarray
    faces: np.ndarray


@dataclass(frozen=True)
class Param:
    """One size parameter: default and valid range (SI units)."""

    default: float
    min: float
    max: float
    unit: str = "m"
    doc: str = ""


@dataclass(frozen=True)
class Shape:
    """A registered shape: its parameters and the functions that build it."""

    name: str
    params: Mapping[str, Param]
    radius: Callable[..., np.ndarray]
    mesh: Callable[..., trimesh.Trimesh]
    pieces: Callable[..., list[np.ndarray]]
    doc: str = ""
    thesis: bool = True
    """One of the five thesis test shapes (False for the modified shapes)."""
    extent: Callable[..., float] = field(default=lambda **p: 0.0)
    """Half-length of the solid along O-O' (m)."""

    def resolve(self, given: Mapping[str, float] | None = None) -> dict[str, float]:
        """Defaults filled in, every value checked against its range (UsageError if not)."""
        given = dict(given or {})
        unknown = sorted(set(given) - set(self.params))
        if unknown:
            raise UsageError(
                f"shape {self.name!r} has no parameter {unknown[0]!r} "
                f"(parameters: {', '.join(self.params)})"
            )
        out = {}
        for key, spec in self.params.items():
            value = float(given.get(key, spec.default))
            if not np.isfinite(value) or not spec.min <= value <= spec.max:
                raise UsageError(
                    f"{self.name} {key}={value:g} {spec.unit} is out of range "
                    f"[{spec.min:g}, {spec.max:g}] {spec.unit}"
                )
            out[key] = value
        check_consistent(self.name, out)
        return out

    def describe(self) -> dict:
        """The ``shapes --json`` entry."""
        return {
            "name": self.name,
            "thesis": self.thesis,
            "doc": self.doc,
            "params": {
                k: {"default": p.default, "min": p.min, "max": p.max, "unit": p.unit}
                for k, p in self.params.items()
            },
        }


def check_consistent(name: str, p: Mapping[str, float]) -> None:
    """UsageError where sizes within their ranges still make no such solid."""
    if name == "torus" and p["major_radius"] <= p["minor_radius"]:
        raise UsageError("torus major_radius must exceed minor_radius (the hole would close)")
    if name == "hyperboloid" and p["end_radius"] <= p["waist_radius"]:
        raise UsageError("hyperboloid end_radius must exceed waist_radius")


# --- radius profiles r(x) ------------------------------------------------------------------


def _inside(x: np.ndarray, half: float) -> np.ndarray:
    return np.abs(x) <= half


def cylinder_radius(x, radius=0.035, length=0.12):
    """r(x) of a cylinder: constant."""
    x = np.asarray(x, float)
    return np.where(_inside(x, length / 2), radius, 0.0)


def cone_radius(x, radius=0.05, length=0.16):
    """r(x) of a right circular cone, base (radius) at x = -length/2, apex at +length/2."""
    x = np.asarray(x, float)
    return np.where(_inside(x, length / 2), radius * (0.5 - x / length), 0.0)


def sphere_radius(x, radius=0.045):
    """r(x) of a sphere."""
    x = np.asarray(x, float)
    return np.sqrt(np.clip(radius**2 - x**2, 0.0, None))


def torus_radius(x, major_radius=0.048, minor_radius=0.042):
    """Outer radius r(x) of a torus whose axis is O-O': R + sqrt(a^2 - x^2)."""
    x = np.asarray(x, float)
    inside = _inside(x, minor_radius)
    return np.where(inside, major_radius + np.sqrt(np.clip(minor_radius**2 - x**2, 0, None)), 0)


def _hyperboloid_c(waist_radius, end_radius, length):
    return (length / 2) / np.sqrt((end_radius / waist_radius) ** 2 - 1.0)


def hyperboloid_radius(x, waist_radius=0.028, end_radius=0.045, length=0.12):
    """r(x) of a one-sheet hyperboloid of revolution: a * sqrt(1 + (x / c)^2)."""
    x = np.asarray(x, float)
    c = _hyperboloid_c(waist_radius, end_radius, length)
    return np.where(_inside(x, length / 2), waist_radius * np.sqrt(1 + (x / c) ** 2), 0.0)


def ovoid_radius(x, radius=0.04, length=0.13, asymmetry=0.25):
    """r(x) of an egg: an ellipse of semi-axes (length/2, radius) skewed by (1 + k x / a)."""
    x = np.asarray(x, float)
    a = length / 2
    u = np.clip(x / a, -1.0, 1.0)
    return np.where(_inside(x, a), radius * np.sqrt(1 - u**2) * (1 + asymmetry * u), 0)


def hexagonal_pyramid_radius(x, radius=0.05, length=0.16):
    """Circumradius of the hexagonal cross-section: linear like the cone's."""
    return cone_radius(x, radius, length)


# --- meshes ---------------------------------------------------------------------------------

_Z_TO_X = np.array([[0.0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]])
"""+90 deg about y: maps a solid built around z onto O-O' (z -> +x)."""


def _trimesh():
    """trimesh, imported on first mesh: it takes ~1-3 s, and listing shapes or loading the
    plugin registry (train, evaluate, plugins) needs none."""
    import trimesh

    return trimesh


def _revolve(
    profile_x: np.ndarray, profile_r: np.ndarray, sections: int = SECTIONS
) -> trimesh.Trimesh:
    """Revolve a closed radius profile (from r=0 to r=0) around O-O' (the x axis)."""
    line = np.column_stack([profile_r, profile_x])
    mesh = _trimesh().creation.revolve(line, sections=sections)
    # revolve works around z; rotate +90 deg about y so that z becomes +x.
    mesh.apply_transform(_Z_TO_X)
    mesh.fix_normals()
    return mesh


def _profile(radius_fn, half: float, n: int = 64, **params) -> tuple[np.ndarray, np.ndarray]:
    x = np.linspace(-half, half, n)
    r = radius_fn(x, **params)
    r[0] = r[-1] = 0.0  # closes the solid with caps of radius 0 on the axis
    return x, r


def _flat_ends(radius_fn, half: float, n: int = 32, **params) -> tuple[np.ndarray, np.ndarray]:
    """Profile with flat end caps (cylinder-like ends)."""
    x = np.linspace(-half, half, n)
    r = radius_fn(x, **params)
    return np.concatenate([[-half], x, [half]]), np.concatenate([[0.0], r, [0.0]])


# The closed radius profiles (x along O-O', r from 0 back to 0) of the revolved solids; the
# mesh revolves one with trimesh, the collision hull takes its points (revolved_points).


def cylinder_profile(radius: float, length: float, sections: int = SECTIONS):
    return _flat_ends(cylinder_radius, length / 2, 2, radius=radius, length=length)


def cone_profile(radius: float, length: float, sections: int = SECTIONS):
    return np.array([-length / 2, -length / 2, length / 2]), np.array([0.0, radius, 0.0])


def sphere_profile(radius: float, sections: int = SECTIONS):
    return _profile(sphere_radius, radius, sections // 2 + 1, radius=radius)


def ovoid_profile(radius: float, length: float, asymmetry: float, sections: int = SECTIONS):
    return _profile(
        ovoid_radius, length / 2, sections, radius=radius, length=length, asymmetry=asymmetry
    )


def torus_profile(major_radius: float, minor_radius: float, sections: int = 32):
    """The tube's circle (``sections`` facets, first point repeated last), as revolved."""
    phi = np.linspace(0.0, 2.0 * np.pi, sections + 1)
    return minor_radius * np.sin(phi), minor_radius * np.cos(phi) + major_radius


def hyperboloid_profile(
    waist_radius: float, end_radius: float, length: float, sections: int = SECTIONS
):
    return _flat_ends(
        hyperboloid_radius, length / 2, 33,
        waist_radius=waist_radius, end_radius=end_radius, length=length,
    )  # fmt: skip


def revolved_surface(x: np.ndarray, r: np.ndarray, sections: int) -> Surface:
    """The profile (x, r) revolved ``sections`` times around O-O' as a triangle surface, in
    the order and to the bit that ``_revolve``'s (or ``torus``'s) trimesh mesh has it:
    vertices slice by slice, those trimesh merges (equal to 8 decimals: the points on the
    axis, a closed profile's repeated point) kept once where first met, zero-area triangles
    dropped. The collision pieces are built from it without importing trimesh (~0.5 s, half
    of a command-line grasp's budget beyond its simulation for a size not cached yet);
    tests/test_answer_imports.py holds it equal to trimesh's meshes over the shapes' ranges.
    The angles, products and signs are ``trimesh.creation.revolve``'s followed by
    ``_Z_TO_X`` (x, y, z) -> (z, y, -x)."""
    x, r = np.asarray(x, float), np.asarray(r, float)
    per = len(x)
    theta = np.linspace(0.0, 2.0 * np.pi, sections + 1)
    vertices = np.column_stack([
        np.tile(x, sections + 1), (np.sin(theta)[:, None] * r).ravel(),
        -(np.cos(theta)[:, None] * r).ravel(),
    ])[:-per]  # fmt: skip
    quad = np.array([0, per, 1, 1, per, per + 1])
    single = np.tile(quad, per - 1).reshape(-1, 3) + np.repeat(np.arange(per - 1), 2)[:, None]
    corners = vertices[single]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    single = single[np.linalg.norm(cross, axis=1) / 2 > 1e-8]
    offsets = np.repeat(np.arange(sections) * per, len(single))[:, None]
    faces = (np.tile(single, (sections, 1)) + offsets) % len(vertices)
    _, first, group = np.unique(np.round(vertices * 1e8), axis=0, return_index=True,
                                return_inverse=True)  # fmt: skip
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    return Surface(vertices[np.sort(first)], rank[group.ravel()][faces])


def cylinder(
    radius: float = 0.035, length: float = 0.12, sections: int = SECTIONS
) -> trimesh.Trimesh:
    """Cylinder of ``radius`` (m) and ``length`` (m) along O-O'."""
    return _revolve(*cylinder_profile(radius, length), sections)


def cone(radius: float = 0.05, length: float = 0.16, sections: int = SECTIONS) -> trimesh.Trimesh:
    """Cone of base ``radius`` (m) at -length/2 and apex at +length/2 (m)."""
    return _revolve(*cone_profile(radius, length), sections)


def sphere(radius: float = 0.045, sections: int = SECTIONS) -> trimesh.Trimesh:
    """Sphere of ``radius`` (m)."""
    return _revolve(*sphere_profile(radius, sections), sections)


def torus(
    major_radius: float = 0.048, minor_radius: float = 0.042, sections: int = SECTIONS
) -> trimesh.Trimesh:
    """Torus around O-O': tube of ``minor_radius`` (m) centred ``major_radius`` (m) from it."""
    mesh = _trimesh().creation.torus(major_radius, minor_radius, sections, 32)
    mesh.apply_transform(_Z_TO_X)
    return mesh


def hyperboloid(
    waist_radius: float = 0.028,
    end_radius: float = 0.045,
    length: float = 0.12,
    sections: int = SECTIONS,
) -> trimesh.Trimesh:
    """One-sheet hyperboloid of revolution with flat ends, waist at x = 0."""
    return _revolve(*hyperboloid_profile(waist_radius, end_radius, length), sections)


def ovoid(
    radius: float = 0.04, length: float = 0.13, asymmetry: float = 0.25, sections: int = SECTIONS
) -> trimesh.Trimesh:
    """Egg: ``length`` (m) along O-O', widest ``radius`` (m), blunt end toward +x."""
    return _revolve(*ovoid_profile(radius, length, asymmetry, sections), sections)


def hexagonal_pyramid_points(radius: float, length: float, sections: int = 6) -> np.ndarray:
    """The pyramid's seven corners: the base hexagon (circumradius ``radius``) at -length/2,
    then the apex. Its trimesh hull keeps them, in this order."""
    angles = np.arange(6) * np.pi / 3 + np.pi / 6
    base = np.column_stack(
        [np.full(6, -length / 2), radius * np.cos(angles), radius * np.sin(angles)]
    )
    return np.vstack([base, np.array([[length / 2, 0.0, 0.0]])])


def hexagonal_pyramid(
    radius: float = 0.05, length: float = 0.16, sections: int = 6
) -> trimesh.Trimesh:
    """Hexagonal pyramid: base circumradius ``radius`` (m) at -length/2, apex at +length/2.
    ``sections`` is accepted for a uniform signature; a hexagon has six."""
    return _trimesh().convex.convex_hull(hexagonal_pyramid_points(radius, length))


# --- convex pieces for Bullet ---------------------------------------------------------------


COLLISION_SECTIONS = 32
"""Facets around the axis of a convex collision hull: the support-point search Bullet runs per
contact is linear in vertices, and 32 facets keep the radius within 0.5% (0.2 mm at 45 mm)."""


def _revolved_hull(profile_fn) -> Callable[..., list[np.ndarray]]:
    """A convex solid of revolution as one hull: its profile revolved with fewer facets, the
    surface's points only (the vertices of its trimesh mesh at those facets)."""

    def pieces(**params) -> list[np.ndarray]:
        x, r = profile_fn(**params, sections=COLLISION_SECTIONS)
        return [revolved_surface(x, r, COLLISION_SECTIONS).vertices]

    return pieces


def hexagonal_pyramid_pieces(radius: float = 0.05, length: float = 0.16) -> list[np.ndarray]:
    """The pyramid as one hull: its seven corners."""
    return [hexagonal_pyramid_points(radius, length)]


def torus_pieces(major_radius: float = 0.048, minor_radius: float = 0.042) -> list[Surface]:
    """The torus as one exact static triangle mesh: the hole stays open and the surface the
    fingers wrap has no internal faces. Convex sectors around O-O' were tried first: the
    fingers curl across the sector cuts and the cut faces' normals knocked them about."""
    x, r = torus_profile(major_radius, minor_radius)
    return [revolved_surface(x, r, COLLISION_SECTIONS)]


def hyperboloid_pieces(
    waist_radius: float = 0.028, end_radius: float = 0.045, length: float = 0.12
) -> list[Surface]:
    """The hyperboloid as one exact static triangle mesh: the waist stays concave. Convex
    slabs along O-O' were tried first: a finger capsule straddling a cut felt the cut faces'
    sideways normals and slid along the waist."""
    x, r = hyperboloid_profile(waist_radius, end_radius, length)
    return [revolved_surface(x, r, COLLISION_SECTIONS)]


# --- the table ------------------------------------------------------------------------------

BUILTIN_SHAPES: tuple[Shape, ...] = (
    Shape(
        "cone",
        {
            "radius": Param(0.05, 0.03, 0.07, doc="base radius"),
            "length": Param(0.16, 0.12, 0.22, doc="base to apex"),
        },
        cone_radius, cone, _revolved_hull(cone_profile),
        doc="right circular cone, base toward the little finger",
        extent=lambda length, **_: length / 2,
    ),
    Shape(
        "torus",
        {
            "major_radius": Param(0.048, 0.044, 0.07, doc="axis to tube centre"),
            "minor_radius": Param(0.042, 0.038, 0.055, doc="tube radius"),
        },
        torus_radius, torus, torus_pieces,
        doc="torus around O-O', hole kept open in collision",
        extent=lambda minor_radius, **_: minor_radius,
    ),
    Shape(
        "sphere",
        {"radius": Param(0.045, 0.035, 0.07)},
        sphere_radius, sphere, _revolved_hull(sphere_profile),
        doc="sphere",
        extent=lambda radius, **_: radius,
    ),
    Shape(
        "hyperboloid",
        {
            "waist_radius": Param(0.028, 0.02, 0.04, doc="radius at x = 0"),
            "end_radius": Param(0.045, 0.035, 0.06, doc="radius at the flat ends"),
            "length": Param(0.12, 0.1, 0.16),
        },
        hyperboloid_radius, hyperboloid, hyperboloid_pieces,
        doc="one-sheet hyperboloid of revolution, waist kept concave in collision",
        extent=lambda length, **_: length / 2,
    ),
    Shape(
        "cylinder",
        {
            "radius": Param(0.035, 0.02, 0.055),
            "length": Param(0.12, 0.1, 0.18),
        },
        cylinder_radius, cylinder, _revolved_hull(cylinder_profile),
        doc="cylinder",
        extent=lambda length, **_: length / 2,
    ),
    Shape(
        "ovoid",
        {
            "radius": Param(0.04, 0.03, 0.055, doc="widest radius"),
            "length": Param(0.13, 0.1, 0.18),
            "asymmetry": Param(0.25, 0.0, 0.4, unit="1", doc="egg skew k"),
        },
        ovoid_radius, ovoid, _revolved_hull(ovoid_profile),
        doc="egg (modified shape)", thesis=False,
        extent=lambda length, **_: length / 2,
    ),
    Shape(
        "hexagonal_pyramid",
        {
            "radius": Param(0.05, 0.03, 0.07, doc="base circumradius"),
            "length": Param(0.16, 0.12, 0.22, doc="base to apex"),
        },
        hexagonal_pyramid_radius, hexagonal_pyramid,
        hexagonal_pyramid_pieces,
        doc="hexagonal pyramid (modified shape)", thesis=False,
        extent=lambda length, **_: length / 2,
    ),
)  # fmt: skip

THESIS_SHAPES: tuple[str, ...] = tuple(s.name for s in BUILTIN_SHAPES if s.thesis)
