"""Training-free identification by fitting each shape family to the absolute joint angles.

The signature (``signature.py``) normalises each line, which is what makes the thesis' DTW
matcher size-invariant, and also what makes a sphere look like a torus and a cylinder like a
hyperboloid: their enhanced lines differ only in scale and in curvature the hand barely feels.
This module keeps the scale. For every shape family it searches the sizes and the object's
position (offset along O-O' and along the fingers) whose *predicted* final joint angles best
explain the measured ones, and names the family with the best penalised fit. It also returns
the fitted sizes, which the DTW matcher cannot.

Forward model (:func:`finger_chain`): eq. 2.3's wrap, theta = s / r(x), played out the way
Algorithm 1 closes this hand. Each long finger is a chain of sphere-swept segments (the URDF's
capsule axes: proximal 45 mm, middle 25 mm, distal 24 mm; radii 9, 9, 8 mm) in its own plane
x = x_f. Stage J3 turns the straight finger about its knuckle until it first meets the object's
section there (a circle of radius ``reach``: r(x) grown by the capsule radius and by the
object's curvature along O-O', ``patterns.reach_profile``); then J2 turns the middle and distal
phalanges until they meet it, then J1 the distal one. A joint that meets nothing closes to its
limit (90 deg): a finger with no object under it is *predicted* to close to its limits, so a far
finger is explained by the fit instead of corrupting it. Where the tangent point lies on the
middle or distal phalanx, the later joints start blocked, which the ``hand`` model of
``patterns.py`` (proximal always tangent) gets wrong on small radii.

Calibration (:class:`Calibration`, ``data/shape_fit.json``, written by
``tools/shape_fit_calibration.py``): the simulated controller stops each stage at a torque
threshold, a little before or after the geometric contact, and an outer finger on a steep flank
slides round it. Per finger and joint group (J3, J0 = J1 + J2), a linear map from the geometric
prediction and the sideways offset of the contact (how far off the finger's plane it touches)
to the measured angle is fitted on simulated grasps of the thesis preset whose configuration
is not on ``tools/invariance.py``'s evaluation grid; its residual spread weights the fit.

Identification: for each family, a precomputed grid of sizes x offsets (predicted angles cached
at first use), then a batched pattern search around the best grid point. The score is the
robust (soft-L1) sum of weighted residuals plus a penalty per size parameter; the lowest score
wins.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache
from importlib import resources

import numpy as np

from .errors import UsageError
from .hand import FINGER_X, KNUCKLE_Z, LONG_FINGERS
from .shapes import BUILTIN_SHAPES, THESIS_SHAPES, Shape, check_consistent

SEGMENTS = (0.045, 0.025, 0.024)
"""Lengths (m) of the capsule axes of the proximal, middle and distal phalanges (URDF): J3 to
J2, J2 to J1, J1 to the centre of the distal capsule's tip cap."""

SEGMENT_PADS = (0.009, 0.009, 0.008)
"""Capsule radii (m) of the proximal, middle and distal phalanges (URDF)."""

JOINT_MAX = math.pi / 2
"""Upper limit of J3, J2 and J1 (URDF): where a joint that meets nothing ends."""

OFFSET_X = (-0.02, 0.02)
"""Range (m) searched for the object's offset along O-O' (twice the thesis preset's)."""

OFFSET_Z = (-0.015, 0.015)
"""Range (m) searched for the object's offset along the fingers."""

FEATURES = ("J3", "J0")
"""Per finger, what is fitted: the proximal angle and the coupled J0 = J1 + J2 (the split of
J0 between J1 and J2 follows the tendon rule, not the shape)."""

GRID_STEPS = {1: 15, 2: 8, 3: 5}
"""Grid values per size parameter, by the family's number of parameters."""

OFFSET_STEPS = (5, 4)
"""Grid values of the offset along O-O' and along the fingers."""

REFINE_ROUNDS = 10
"""Moves or halvings of the pattern search's step after the grid."""

_REACH_SAMPLES = 13
_TABLE = {s.name: s for s in BUILTIN_SHAPES}
_ZK = np.array([KNUCKLE_Z[f] for f in LONG_FINGERS])
_XF = np.array([FINGER_X[f] for f in LONG_FINGERS])


# --- the forward model ------------------------------------------------------------------------


def first_contact(py, pz, phi0, length, centre_y, centre_z, reach, limit=JOINT_MAX):
    """Absolute angle at which a sphere-swept segment turning about (py, pz) from angle ``phi0``
    first meets a circle of radius ``reach`` (0: nothing there) centred at (centre_y, centre_z);
    ``phi0 + limit`` when it meets nothing, ``phi0`` when it is already touching.

    Angles are flexions in the finger plane: direction (-sin phi, cos phi), 0 along +z, growing
    toward -y (toward the object). The segment meets the circle first along its tangent when
    the tangent point lies within ``length`` of the pivot, else with its tip.
    """
    vy, vz = centre_y - py, centre_z - pz
    dist = np.hypot(vy, vz)
    safe = np.maximum(dist, 1e-12)
    towards = np.arctan2(-vy, vz)
    towards = phi0 + np.mod(towards - phi0 + np.pi, 2 * np.pi) - np.pi
    tangent = np.sqrt(np.clip(dist**2 - reach**2, 0.0, None))
    phi_tangent = towards - np.arcsin(np.clip(reach / safe, 0.0, 1.0))
    cos_tip = (dist**2 + length**2 - reach**2) / (2.0 * length * safe)
    phi_tip = towards - np.arccos(np.clip(cos_tip, -1.0, 1.0))
    phi_in = np.where(tangent <= length, phi_tangent, phi_tip)
    phi_out = 2.0 * towards - phi_in
    present = reach > 0
    reachable = present & (dist - length <= reach)
    touching = (present & (dist <= reach)) | (reachable & (phi_in <= phi0) & (phi0 <= phi_out))
    ahead = reachable & (phi0 < phi_in)
    free = phi0 + limit
    return np.where(touching, phi0, np.where(ahead, np.minimum(phi_in, free), free))


def finger_chain(reach, reach_distal, centre_y, centre_z) -> np.ndarray:
    """Final (J3, J2, J1) of the long fingers closing by Algorithm 1 on circular sections.

    ``reach`` (..., 4): where each finger's proximal and middle capsule axes meet the object
    (0: no object under the finger); ``reach_distal`` the same for the thinner distal capsule;
    ``centre_y``, ``centre_z`` (broadcastable) the section's centre in the finger plane, palm
    frame. Returns (..., 3, 4): rows J3, J2, J1 (rad).
    """
    l1, l2, l3 = SEGMENTS
    reach = np.asarray(reach, dtype=float)
    py = np.zeros_like(reach)
    pz = np.broadcast_to(_ZK, reach.shape)
    a1 = first_contact(py, pz, 0.0, l1 + l2 + l3, centre_y, centre_z, reach)
    py, pz = py - l1 * np.sin(a1), pz + l1 * np.cos(a1)
    a2 = first_contact(py, pz, a1, l2 + l3, centre_y, centre_z, reach)
    py, pz = py - l2 * np.sin(a2), pz + l2 * np.cos(a2)
    a3 = first_contact(py, pz, a2, l3, centre_y, centre_z, reach_distal)
    return np.stack([a1, a2 - a1, a3 - a2], axis=-2)


_DU = np.linspace(-SEGMENT_PADS[0], SEGMENT_PADS[0], _REACH_SAMPLES)
_GROW = np.sqrt(np.clip(SEGMENT_PADS[0] ** 2 - _DU**2, 0.0, None))
_SIDE = np.abs(_DU) / SEGMENT_PADS[0]


def _reach(radius_fn, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Batched ``patterns.reach_profile`` for the 9 mm capsules (t: (..., 4)), and how far off
    the finger's plane the contact lies as a fraction of the pad (0 in the plane, 1 at the
    capsule's side)."""
    with np.errstate(invalid="ignore"):
        r = radius_fn(t[..., None] + _DU)
    grown = np.where(r > 0, r + _GROW, 0.0)  # NaN (no such solid) counts as nothing there
    best = grown.argmax(axis=-1)
    return np.take_along_axis(grown, best[..., None], -1)[..., 0], _SIDE[best]


@cache
def _clearance_u() -> tuple[np.ndarray, ...]:
    from .scene import CLEARANCES

    # scene.place_object samples the profile every 0.5 mm; every 1 mm moves the depth < 0.1 mm
    u = np.linspace(-0.3, 0.3, 601)
    return tuple(u[(u >= lo) & (u <= hi)] for (lo, hi), _ in CLEARANCES)


@cache
def _scene_constants() -> tuple[tuple[float, ...], float, float]:
    from .scene import CLEARANCES, GRASP_Z, STANDOFF

    return tuple(depth for _, depth in CLEARANCES), STANDOFF, GRASP_Z


def nominal_centre(shape: Shape, params: Mapping[str, np.ndarray]) -> tuple[np.ndarray, float]:
    """(y, z) of the object's axis at zero offset, as ``scene.place_object`` puts it (no
    rotation): STANDOFF clear of the palm and the open thumb, deeper for a larger object."""
    depths, standoff, grasp_z = _scene_constants()
    sizes = {k: np.asarray(v, dtype=float)[..., None] for k, v in params.items()}
    y0 = np.zeros(np.broadcast_shapes(*(v.shape[:-1] for v in sizes.values())))
    for u, depth in zip(_clearance_u(), depths, strict=True):
        with np.errstate(invalid="ignore"):
            r = shape.radius(u, **sizes)
        y0 = np.minimum(y0, -depth - standoff - np.where(r > 0, r, 0.0).max(axis=-1))
    return y0, grasp_z


def _sections(shape: Shape, params: Mapping[str, np.ndarray], offset) -> tuple[np.ndarray, ...]:
    """What each finger meets, batched: reach and sideways fraction (..., 4), and the
    section's centre y (..., 1) and z (..., 1) in the finger plane."""
    offset = np.asarray(offset, dtype=float)
    y0, z0 = nominal_centre(shape, params)
    sizes = {k: np.asarray(v, dtype=float)[..., None, None] for k, v in params.items()}
    reach, side = _reach(lambda u: shape.radius(u, **sizes), _XF - offset[..., 0:1])
    return reach, side, y0[..., None], z0 + offset[..., 1:2]


def _chain_features(reach, side, centre_y, centre_z) -> np.ndarray:
    """(..., 3, 4): J3, J0 and the sideways fraction (-1 where the finger meets nothing)."""
    pad_step = SEGMENT_PADS[0] - SEGMENT_PADS[2]
    reach_distal = np.where(reach > pad_step, reach - pad_step, 0.0)
    angles = finger_chain(reach, reach_distal, centre_y, centre_z)
    side = np.where(reach > 0, side, -1.0)
    return np.stack([angles[..., 0, :], angles[..., 1, :] + angles[..., 2, :], side], axis=-2)


def geometric_features(shape: Shape, params: Mapping[str, np.ndarray], offset) -> np.ndarray:
    """Uncalibrated model, batched: (..., 3, 4) = predicted J3, J0 and the contact's sideways
    fraction per finger, for sizes ``params`` (arrays of one shape) and ``offset`` (..., 2) =
    (along O-O', along the fingers) in m. A finger with no object under it gets J3 = 90 deg,
    J0 = 180 deg and sideways fraction -1. The distal capsule (8 mm) is taken to meet the
    section 1 mm further in than the others (9 mm)."""
    return _chain_features(*_sections(shape, params, offset))


# --- calibration ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Calibration:
    """Linear correction of the geometric model, per joint group (rows J3, J0) and finger.

    predicted = intercept + gain * geometric + side * sideways fraction, for fingers with the
    object under them (a finger that misses keeps its joint limits). ``sigma`` is the
    residual spread that weights each angle in the fit; ``loss_scale`` the soft-L1 knee (in
    sigmas); ``penalty`` the score added per size parameter.
    """

    intercept: np.ndarray = field(default_factory=lambda: np.zeros((2, 4)))
    gain: np.ndarray = field(default_factory=lambda: np.ones((2, 4)))
    side: np.ndarray = field(default_factory=lambda: np.zeros((2, 4)))
    sigma: np.ndarray = field(default_factory=lambda: np.array([[0.03] * 4, [0.1] * 4]))
    loss_scale: float = 2.0
    penalty: float = 0.0
    source: str = "defaults"

    def __post_init__(self) -> None:
        for name in ("intercept", "gain", "side", "sigma"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (2, 4) or not np.all(np.isfinite(value)):
                raise UsageError(f"shape-fit calibration {name} must be 2 x 4 finite numbers")
            object.__setattr__(self, name, value)
        if not np.all(self.sigma > 0):
            raise UsageError("shape-fit calibration sigma must be positive")
        if not (self.loss_scale > 0 and np.isfinite(self.penalty) and self.penalty >= 0):
            raise UsageError("shape-fit calibration loss_scale must be > 0 and penalty >= 0")

    def apply(self, geometric: np.ndarray) -> np.ndarray:
        """(..., 3, 4) geometric features -> (..., 2, 4) predicted J3, J0."""
        angles, side = geometric[..., :2, :], geometric[..., 2:3, :]
        corrected = self.intercept + self.gain * angles + self.side * np.clip(side, 0.0, None)
        return np.where(side >= 0, corrected, angles)

    def to_dict(self) -> dict:
        return {
            "intercept": self.intercept.tolist(),
            "gain": self.gain.tolist(),
            "side": self.side.tolist(),
            "sigma": self.sigma.tolist(),
            "loss_scale": self.loss_scale,
            "penalty": self.penalty,
        }

    @classmethod
    def from_dict(cls, doc: Mapping, source: str = "dict") -> Calibration:
        try:
            return cls(
                intercept=doc["intercept"],
                gain=doc["gain"],
                side=doc["side"],
                sigma=doc["sigma"],
                loss_scale=float(doc["loss_scale"]),
                penalty=float(doc["penalty"]),
                source=source,
            )
        except (KeyError, TypeError, ValueError) as exc:
            if isinstance(exc, UsageError):
                raise
            raise UsageError(f"shape-fit calibration ({source}) is malformed: {exc}") from None


@cache
def load_calibration() -> Calibration:
    """The calibration shipped in ``data/shape_fit.json`` (the identity when absent)."""
    try:
        text = resources.files("tactile_bullet").joinpath("data/shape_fit.json").read_text()
    except (FileNotFoundError, OSError):
        return Calibration()
    return Calibration.from_dict(json.loads(text), "data/shape_fit.json")


# --- fitting ----------------------------------------------------------------------------------


def measured_features(angles) -> np.ndarray:
    """(2, 4) J3 and J0 = J2 + J1 per long finger from final angles (3, 4): rows J3, J2, J1,
    columns ff, mf, rf, lf (rad), as ``GraspRecord.fci_angles`` gives them."""
    try:
        arr = np.asarray(angles, dtype=float)
    except (TypeError, ValueError):
        raise UsageError("joint angles must be numbers (3 x 4: J3, J2, J1 x ff..lf)") from None
    if arr.shape != (3, 4):
        raise UsageError(
            f"joint angles must be a 3 x 4 array (rows J3, J2, J1; columns ff, mf, rf, lf), "
            f"got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise UsageError("joint angles contain NaN or infinity")
    return np.stack([arr[0], arr[1] + arr[2]])


@dataclass(frozen=True)
class FamilyFit:
    """Best fit of one shape family: sizes (m), offset (m: along O-O', along the fingers),
    ``residual`` the RMS angle error (rad) over the eight fitted angles, ``score`` the
    penalised robust cost the identification compares, ``predicted`` (2, 4) J3, J0."""

    shape: str
    params: dict[str, float]
    offset: tuple[float, float]
    residual: float
    score: float
    predicted: np.ndarray

    def summary(self) -> dict:
        return {
            "params": self.params,
            "offset_m": list(self.offset),
            "residual_rad": self.residual,
            "score": self.score,
        }


@dataclass(frozen=True)
class ShapeFit:
    """Outcome of :func:`fit_shape`: the best family and every family's fit."""

    shape: str
    fits: dict[str, FamilyFit]

    @property
    def best(self) -> FamilyFit:
        return self.fits[self.shape]

    @property
    def params(self) -> dict[str, float]:
        """The fitted sizes of the identified shape (m)."""
        return self.best.params

    @property
    def residual(self) -> float:
        return self.best.residual

    def summary(self) -> dict:
        """The ``shape_fit`` block of ``grasp --json``."""
        return {
            "shape": self.shape,
            "params": self.best.params,
            "offset_m": list(self.best.offset),
            "residual": self.best.residual,
            "scores": {name: fit.score for name, fit in self.fits.items()},
        }


class _Family:
    """One shape family's search space: sizes and offsets, normalised to [0, 1]."""

    def __init__(self, shape: Shape) -> None:
        self.shape = shape
        self.names = tuple(shape.params)
        self.lo = np.array([shape.params[k].min for k in self.names] + [OFFSET_X[0], OFFSET_Z[0]])
        self.hi = np.array([shape.params[k].max for k in self.names] + [OFFSET_X[1], OFFSET_Z[1]])
        steps = GRID_STEPS.get(len(self.names), 6)
        axes = [np.linspace(0.0, 1.0, steps)] * len(self.names)
        axes += [np.linspace(0.0, 1.0, n) for n in OFFSET_STEPS]
        self.spacing = np.array([1.0 / (len(a) - 1) for a in axes])
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))
        self.grid = grid[self.valid(grid)]
        self.grid_geometry = self.geometry(self.grid)
        self._cal: Calibration | None = None
        self._pred = self.grid_geometry[..., :2, :]

    def grid_prediction(self, cal: Calibration) -> np.ndarray:
        """The grid's predicted angles under ``cal`` (kept for the last calibration used)."""
        if self._cal is not cal:
            self._cal, self._pred = cal, cal.apply(self.grid_geometry)
        return self._pred

    def values(self, z: np.ndarray) -> np.ndarray:
        return self.lo + np.clip(z, 0.0, 1.0) * (self.hi - self.lo)

    def valid(self, z: np.ndarray) -> np.ndarray:
        v = self.values(z)
        p = {k: v[:, i] for i, k in enumerate(self.names)}
        ok = np.ones(len(z), dtype=bool)
        if self.shape.name == "torus":
            ok &= p["major_radius"] > p["minor_radius"]
        if self.shape.name == "hyperboloid":
            ok &= p["end_radius"] > p["waist_radius"] * 1.001
        return ok

    def sections(self, z: np.ndarray) -> tuple[np.ndarray, ...]:
        v = self.values(z)
        params = {k: v[:, i] for i, k in enumerate(self.names)}
        return _sections(self.shape, params, v[:, -2:])

    def geometry(self, z: np.ndarray) -> np.ndarray:
        return _chain_features(*self.sections(z))


@cache
def _family(name: str) -> _Family:
    return _Family(_TABLE[name])


def _resolve_family(shape: str | Shape) -> _Family:
    name = shape.name if isinstance(shape, Shape) else shape
    if name not in _TABLE:
        raise UsageError(f"shape-fit has no model of shape {name!r} (shapes: {', '.join(_TABLE)})")
    return _family(name)


def _costs(measured: np.ndarray, predicted: np.ndarray, cal: Calibration) -> np.ndarray:
    """Robust (soft-L1) cost of each predicted (.., 2, 4) against the measured (2, 4)."""
    e = (measured - predicted) / cal.sigma
    c = cal.loss_scale
    return (2.0 * c * c * (np.sqrt(1.0 + (e / c) ** 2) - 1.0)).sum(axis=(-2, -1))


def fit_family(angles, shape: str | Shape, calibration: Calibration | None = None) -> FamilyFit:
    """Sizes and offset of ``shape`` that best explain final angles (3, 4): grid, then a
    batched pattern search (+-step along each normalised coordinate, halved when no move
    helps)."""
    measured = measured_features(angles)
    cal = load_calibration() if calibration is None else calibration
    fam = _resolve_family(shape)
    return _fit(measured, [fam], cal)[fam.shape.name]


def _fit(measured: np.ndarray, fams: Sequence[_Family], cal: Calibration) -> dict[str, FamilyFit]:
    """Every family's fit at once: the pattern search runs the families in lockstep so that
    each round is one pass of the finger chain over all their candidates."""
    state = []
    for fam in fams:
        cost = _costs(measured, fam.grid_prediction(cal), cal)
        best = int(np.argmin(cost))
        dims = fam.grid.shape[1]
        state.append(
            [fam, fam.grid[best], float(cost[best]), fam.spacing / 2.0,
             np.concatenate([np.eye(dims), -np.eye(dims)])]
        )  # fmt: skip
    for _ in range(REFINE_ROUNDS):
        parts, owners = [], []
        for k, (fam, z, _, step, moves) in enumerate(state):
            cand = np.clip(z + moves * step, 0.0, 1.0)
            cand = cand[fam.valid(cand)]
            if cand.size:
                parts.append((cand, fam.sections(cand)))
                owners.append(k)
        if not parts:
            break
        joined = [np.concatenate([p[1][i] for p in parts]) for i in range(4)]
        cost = _costs(measured, cal.apply(_chain_features(*joined)), cal)
        start = 0
        for k, (cand, _) in zip(owners, parts, strict=True):
            c = cost[start : start + len(cand)]
            start += len(cand)
            j = int(np.argmin(c))
            if c[j] < state[k][2]:
                state[k][1], state[k][2] = cand[j], float(c[j])
            else:
                state[k][3] = state[k][3] / 2.0
    out = {}
    for fam, z, cost, _, _ in state:
        values = fam.values(z[None])[0]
        predicted = cal.apply(fam.geometry(z[None]))[0]
        out[fam.shape.name] = FamilyFit(
            shape=fam.shape.name,
            params={k: float(values[i]) for i, k in enumerate(fam.names)},
            offset=(float(values[-2]), float(values[-1])),
            residual=float(np.sqrt(np.mean((measured - predicted) ** 2))),
            score=cost + cal.penalty * len(fam.names),
            predicted=predicted,
        )
    return out


def fit_shape(
    angles,
    families: Sequence[str] = THESIS_SHAPES,
    calibration: Calibration | None = None,
) -> ShapeFit:
    """Fit every family in ``families`` to final angles (3, 4) and name the best-scoring one.

    The second training-free identifier next to ``patterns.identify`` (DTW on the normalised
    signature): it reads absolute angles, so scale separates sphere from torus and cylinder
    from hyperboloid, and a finger that closed to its limits is explained by the model.
    """
    measured = measured_features(angles)
    names = list(dict.fromkeys(families))
    if not names:
        raise UsageError("shape-fit needs at least one shape family")
    cal = load_calibration() if calibration is None else calibration
    fits = _fit(measured, [_resolve_family(n) for n in names], cal)
    return ShapeFit(min(fits, key=lambda n: fits[n].score), fits)


def predicted_angles(
    shape: str | Shape,
    params: Mapping[str, float] | None = None,
    offset: tuple[float, float] = (0.0, 0.0),
    calibration: Calibration | None = None,
) -> np.ndarray:
    """(2, 4) J3 and J0 per long finger the model predicts for ``shape`` at sizes ``params``
    (defaults filled in, range-checked) and ``offset`` (m, along O-O' and along the fingers)."""
    fam = _resolve_family(shape)
    values = fam.shape.resolve(params)
    check_consistent(fam.shape.name, values)
    off = np.asarray(offset, dtype=float)
    if off.shape != (2,) or not np.all(np.isfinite(off)):
        raise UsageError("offset must be two finite numbers (m): along O-O', along the fingers")
    cal = load_calibration() if calibration is None else calibration
    geo = geometric_features(
        fam.shape, {k: np.array([v]) for k, v in values.items()}, off[None]
    )
    return cal.apply(geo)[0]
