"""Does the named family's surface explain where the grasp touched? Contact points, not normals.

The axis rule (:mod:`.revolution`) sees objects that are no solid of revolution. An egg, a pear
or a spool *is* one, so its normals meet an axis; what gives it away is its profile along that
axis, which no family has: an egg bulges too gently for a sphere and too much for a cylinder.
:func:`profile_residuals` fits the named family's whole surface, ends included, to every
contact point of a grasp, the axis and the family's sizes free (the sizes within the family's
range widened by ``SLACK``), and returns the RMS distance (m) of the points from it.

The surfaces, in the meridian half-plane (s along the axis from the object's centre s0, rho
from the axis):

- cylinder: the side rho = R for |s| <= L/2 and the two flat caps;
- cone: the side from (-L/2, R) to the apex (L/2, 0) and the flat base, either way round;
- hyperboloid: rho = a sqrt(1 + s^2 / c^2) for |s| <= L/2 (c from the end radius e > a) and
  the flat ends;
- sphere: a sphere (fitted directly, algebraically: any axis through its centre fits).

The torus is not judged: its tube's facets (32 around it) put its own contact points 3-13 mm
off the best torus on 2.5% of its training grasps, so a threshold there would flag nothing
(4.6-5.3 mm at 1%: docs/robustness.md, the ninth replicate's declaration). Its surface,
rho = R + sqrt(r^2 - s^2) on the outer rim, is fitted only to ask whether a grasp the sphere
does not explain is a torus read as a sphere (:func:`torus_residuals`, for
:meth:`.contact_check.ContactCheck.contact_names`).

The fit is batched over grasps and starts (Levenberg-Marquardt on a soft-L1 loss, with a
forward-difference Jacobian): the axis that the normals give and the palm's own x axis, each
with the sizes at three places in their ranges; the axis' tilt is bounded to ``TILT``, as the
objects lie along O-O'.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .revolution import MIN_LINKS, axis_fits, link_contacts, padded
from .robust_lm import minimise

SLACK = 0.15
"""How far (a fraction of each range) a fitted size may leave the family's range."""
KNEE = 0.001
"""Soft-L1 knee (m): a single odd contact point does not move the fit much."""
ITERATIONS = 20
TILT = 0.7
"""Largest tilt (slope) of the axis from the palm's x axis: 35 deg."""
MIN_POINTS = 7
"""Contact points a fit needs: it has up to 8 unknowns, but starts from the axis the axis rule
fitted; 7 separate a hexagonal prism from a cylinder, 5 let a cylinder fit diverge
(docs/robustness.md, the seventh replicate's declaration)."""
SIZE_STARTS = (-1.0, 0.0, 1.0)
"""Starting sizes, as the logistic map's argument (-1, 0, 1: a quarter, half, three quarters
of the way through each widened range)."""

RANGES: dict[str, tuple[tuple[float, float], ...]] = {
    "cylinder": ((0.02, 0.055), (0.10, 0.18)),  # radius, length
    "cone": ((0.03, 0.07), (0.12, 0.22)),  # base radius, length
    "hyperboloid": ((0.02, 0.04), (1.05, 3.0), (0.10, 0.16)),  # waist, end / waist, length
    "sphere": ((0.035, 0.07),),  # radius
}
"""Each modelled family's size ranges (m), those of ``objects/shapes.py``; the hyperboloid's
end radius as a ratio to its waist, kept above 1 (a waist, never a bulge)."""
FAMILIES = tuple(RANGES)
"""The families an answer is judged by (:func:`profile_residuals`)."""
TORUS_RANGES = ((0.044, 0.07), (0.038, 0.055))
"""The torus's distance from the axis to its tube's centre and the tube's radius (m), those
of ``objects/shapes.py``: fitted by :func:`torus_residuals`, never judged."""
_SIZE_RANGES = {**RANGES, "torus": TORUS_RANGES}


def _sizes(z: np.ndarray, family: str) -> list[np.ndarray]:
    """The sizes from their unbounded forms: a logistic map onto the widened ranges."""
    out = []
    for k, (lo, hi) in enumerate(_SIZE_RANGES[family]):
        pad = SLACK * (hi - lo)
        out.append(lo - pad + (hi - lo + 2 * pad) / (1.0 + np.exp(-np.clip(z[..., k], -30, 30))))
    return out


def _segment(s, rho, s1, r1, s2, r2):
    """Distance from (s, rho) to the segment (s1, r1)-(s2, r2) of the meridian half-plane."""
    ds, dr = s2 - s1, r2 - r1
    length2 = np.maximum(ds * ds + dr * dr, 1e-12)
    t = np.clip(((s - s1) * ds + (rho - r1) * dr) / length2, 0.0, 1.0)
    return np.hypot(s - (s1 + t * ds), rho - (r1 + t * dr))


def _distances(v: np.ndarray, points: np.ndarray, family: str, sign: float) -> np.ndarray:
    """Each point's distance (..., k) from the family's surface with parameters v (..., 5 +
    sizes) = the axis' bounded tilts (ty, tz), where it crosses x = 0 (cy, cz), the centre s0
    along it, then the sizes' unbounded forms. ``sign`` turns a cone round."""
    ty, tz = TILT * np.tanh(v[..., 0]), TILT * np.tanh(v[..., 1])
    d = np.stack([np.ones_like(ty), ty, tz], axis=-1)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    c = np.stack([np.zeros_like(ty), v[..., 2], v[..., 3]], axis=-1)
    q = points - c[..., None, :]
    along = np.einsum("...kj,...j->...k", q, d)
    rho = np.linalg.norm(q - along[..., None] * d[..., None, :], axis=-1)
    s = sign * (along - v[..., 4, None])
    p = [x[..., None] for x in _sizes(v[..., 5:], family)]
    zero = np.zeros_like(p[0])
    if family == "cylinder":
        r, h = p[0], p[1] / 2
        return np.minimum(_segment(s, rho, -h, r, h, r),
                          np.minimum(_segment(s, rho, -h, zero, -h, r),
                                     _segment(s, rho, h, zero, h, r)))  # fmt: skip
    if family == "cone":
        r, h = p[0], p[1] / 2
        return np.minimum(_segment(s, rho, -h, r, h, zero), _segment(s, rho, -h, zero, -h, r))
    if family == "torus":  # the tube: a circle of radius p[1] centred p[0] off the axis
        return np.abs(np.hypot(rho - p[0], s) - p[1])
    waist, ratio, h = p[0], np.maximum(p[1], 1.0 + 1e-3), p[2] / 2
    end = waist * ratio
    c2 = h * h / (ratio**2 - 1.0)
    profile = waist * np.sqrt(1.0 + s * s / c2)
    slope = waist * s / (c2 * profile)
    side = np.where(np.abs(s) <= h, np.abs(rho - profile) / np.sqrt(1.0 + slope**2), np.inf)
    ends = np.minimum(_segment(s, rho, -h, zero, -h, end), _segment(s, rho, h, zero, h, end))
    return np.minimum(side, ends)


def _fit(points: np.ndarray, mask: np.ndarray, axes: np.ndarray, family: str) -> np.ndarray:
    """RMS distance (m) of each grasp's points from the best surface of ``family``."""
    g, n = len(points), len(RANGES[family])
    tilt = np.arctanh(np.clip(axes[:, :2] / TILT, -0.95, 0.95))
    w = mask / np.maximum(mask.sum(axis=1, keepdims=True), 1)
    centre = (points[..., 0] * w).sum(axis=1)
    starts = []
    for square in (False, True):
        for z in SIZE_STARTS:
            v = np.zeros((g, 5 + n))
            v[:, :2] = 0.0 if square else tilt
            v[:, 2:4] = axes[:, 2:4]
            v[:, 4] = centre
            v[:, 5:] = z
            starts.append(v)
    v = np.stack(starts, axis=1)  # (g, starts, params)
    best = np.full(g, np.inf)
    for sign in (1.0, -1.0) if family == "cone" else (1.0,):
        best = np.minimum(best, _levenberg_marquardt(v, points, mask, family, sign))
    return best


def _levenberg_marquardt(v, points, mask, family, sign, params: bool = False):
    """RMS distance of each grasp's points from the surface its best start reaches, the
    Jacobian by forward differences (and, with ``params``, that surface's parameters, g x
    (5 + sizes), as :func:`_distances` takes them)."""
    pts = points[:, None]
    wm = mask[:, None].astype(float)
    eye = np.eye(v.shape[-1])
    step = 1e-7

    def terms(params, jacobian):
        e = _distances(params, pts, family, sign) * wm
        if not jacobian:
            return e, None
        jac = np.stack([(_distances(params + step * eye[j], pts, family, sign) * wm - e) / step
                        for j in range(v.shape[-1])], axis=-1)  # fmt: skip
        return e, jac

    e_best, theta = minimise(v, terms, wm, KNEE, ITERATIONS)
    rms = np.sqrt((e_best**2).sum(axis=1) / np.maximum(mask.sum(axis=1), 1))
    return (rms, theta) if params else rms


def _best_spheres(points: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centres (g, 3), radii (g,)) of each grasp's algebraic best sphere through its points."""
    centres, radii = np.zeros((len(points), 3)), np.zeros(len(points))
    for i in range(len(points)):
        x = points[i][mask[i]]
        a = np.c_[2.0 * x, np.ones(len(x))]
        sol = np.linalg.lstsq(a, (x**2).sum(axis=1), rcond=None)[0]
        centres[i] = sol[:3]
        radii[i] = np.sqrt(max(sol[3] + sol[:3] @ sol[:3], 0.0))
    return centres, radii


def _sphere_offsets(points: np.ndarray, mask: np.ndarray) -> list[np.ndarray]:
    """Each grasp's points' signed distances off its algebraic best sphere (radius held to the
    family's widened range)."""
    lo, hi = RANGES["sphere"][0]
    pad = SLACK * (hi - lo)
    centres, radii = _best_spheres(points, mask)
    return [np.linalg.norm(points[i][mask[i]] - centres[i], axis=1)
            - np.clip(radii[i], lo - pad, hi + pad) for i in range(len(points))]  # fmt: skip


def _sphere(points: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """RMS distance of each grasp's points from its algebraic best sphere (radius held to the
    family's widened range)."""
    return np.array([np.sqrt(np.mean(off**2)) for off in _sphere_offsets(points, mask)])


def sphere_offsets(record) -> np.ndarray | None:
    """One grasp's contact points' signed distances (m) off their best sphere, as the profile
    rule fits it (for pictures); None with too few contacts."""
    points = _judged(record)
    if points is None:
        return None
    return _sphere_offsets(points[None], np.ones((1, len(points)), dtype=bool))[0]


def _torus(points: np.ndarray, mask: np.ndarray, params: bool = False):
    """RMS distance of each grasp's points from its best torus around an axis near the palm's
    x: started at the points' best sphere's centre (a torus grasped round its rim has its
    centre there; the normals' axis is a poor start on a torus, whose rim normals nearly share
    a plane), the axis untilted, the sizes at three places each in their ranges."""
    centres, _ = _best_spheres(points, mask)
    starts = []
    for major in SIZE_STARTS:
        for minor in SIZE_STARTS:
            v = np.zeros((len(points), 7))
            v[:, 2:4] = centres[:, 1:3]
            v[:, 4] = centres[:, 0]
            v[:, 5], v[:, 6] = major, minor
            starts.append(v)
    return _levenberg_marquardt(np.stack(starts, axis=1), points, mask, "torus", 1.0, params)


def torus_fit(record) -> dict | None:
    """One grasp's best torus (what :func:`torus_residuals` measures), for pictures: ``point``
    (where its axis crosses x = 0), ``direction`` (the axis, unit), ``centre`` (along it from
    ``point``), ``major_radius``, ``minor_radius`` (m), ``residual`` (m, RMS), and for each
    contact point ``along`` (m, along the axis from the centre) and ``off`` (m, signed, off
    the surface); None with too few contacts."""
    points = _judged(record)
    if points is None:
        return None
    rms, theta = _torus(points[None], np.ones((1, len(points)), dtype=bool), params=True)
    v = theta[0]
    direction = np.array([1.0, TILT * np.tanh(v[0]), TILT * np.tanh(v[1])])
    major, minor = (float(x) for x in _sizes(v[5:], "torus"))
    point, direction = np.array([0.0, v[2], v[3]]), direction / np.linalg.norm(direction)
    q = points - point
    along = q @ direction
    rho = np.linalg.norm(q - along[:, None] * direction, axis=1)
    s = along - v[4]
    return {"point": point, "centre": float(v[4]), "direction": direction,
            "major_radius": major, "minor_radius": minor, "residual": float(rms[0]),
            "along": s, "off": np.hypot(rho - major, s) - minor}  # fmt: skip


def _judged(record) -> np.ndarray | None:
    """A grasp's contact points where it has enough of them (``MIN_POINTS`` points on
    ``MIN_LINKS`` links) for a verdict, else None."""
    points = np.asarray(getattr(record, "contact_position", ()), dtype=float).reshape(-1, 3)
    if len(points) >= MIN_POINTS and len(link_contacts(record)[0]) >= MIN_LINKS:
        return points
    return None


def torus_residuals(records: Sequence) -> list[float | None]:
    """How far (m, RMS) each grasp's contact points lie from their best torus (its sizes
    within the torus's widened ranges); None with too few contacts (as
    :func:`profile_residuals`)."""
    out: list[float | None] = [None] * len(records)
    todo = [(i, p) for i, p in enumerate(map(_judged, records)) if p is not None]
    if todo:
        points, mask = padded([p for _, p in todo])
        for (i, _), value in zip(todo, _torus(points, mask), strict=True):
            out[i] = float(value)
    return out


def profile_residuals(records: Sequence, families: Sequence[str],
                      axes: Sequence[np.ndarray | None] | None = None) -> list[float | None]:
    """How far (m, RMS) each grasp's contact points lie from the best surface of the family
    named for it; None for a family not modelled (the torus, a plugin's), with fewer than
    ``MIN_LINKS`` touching links or fewer than ``MIN_POINTS`` contact points. ``axes``: each
    grasp's axis where the caller has fitted it already (:func:`.revolution.axis_fits`), else
    fitted here."""
    out: list[float | None] = [None] * len(records)
    todo, contacts = [], []
    for i, (record, family) in enumerate(zip(records, families, strict=True)):
        if str(family) not in RANGES:
            continue
        points = _judged(record)
        if points is not None:
            todo.append(i)
            contacts.append(points)
    if not todo:
        return out
    points, mask = padded(contacts)
    names = np.array([str(families[i]) for i in todo])
    values = np.zeros(len(todo))
    rows = np.flatnonzero(names == "sphere")
    if len(rows):
        values[rows] = _sphere(points[rows], mask[rows])
    others = np.flatnonzero(names != "sphere")
    if len(others):
        given = None if axes is None else [axes[todo[j]] for j in others]
        if given is None or any(a is None for a in given):
            given = axis_fits([records[todo[j]] for j in others])[1]
        start = np.stack(given)
        for family in FAMILIES:
            pick = np.flatnonzero(names[others] == family)
            if len(pick):
                rows = others[pick]
                values[rows] = _fit(points[rows], mask[rows], start[pick], family)
    for i, value in zip(todo, values, strict=True):
        out[i] = float(value)
    return out
