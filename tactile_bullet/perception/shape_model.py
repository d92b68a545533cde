"""The shape fit's forward model: the final joint angles Algorithm 1 gives on a known object.

Eq. 2.3's wrap, theta = s / r(x), played out the way Algorithm 1 closes this hand: each long
finger is a chain of sphere-swept segments (the URDF's capsules) in its own plane x = x_f;
stage J3 turns the straight finger about its knuckle until it first meets the object's section
there, then J2 turns the middle and distal phalanges, then J1 the distal one. A joint that meets
nothing closes to its limit. :class:`Calibration` (``data/shape_fit.json``) maps the geometric
prediction to what the simulated controller measures, per finger and joint group.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Mapping
from contextlib import contextmanager, nullcontext
from contextvars import ContextVar
from dataclasses import dataclass, field
from functools import cache
from importlib import resources

import numpy as np

from ..errors import UsageError
from ..hand import FINGER_X, KNUCKLE_Z, LONG_FINGERS
from ..objects.shapes import Shape

SEGMENTS = (0.045, 0.025, 0.024)
"""Lengths (m) of the capsule axes of the proximal, middle and distal phalanges (URDF): J3 to
J2, J2 to J1, J1 to the centre of the distal capsule's tip cap."""

SEGMENT_PADS = (0.009, 0.009, 0.008)
"""Capsule radii (m) of the proximal, middle and distal phalanges (URDF)."""

JOINT_MAX = math.pi / 2
"""Upper limit of J3, J2 and J1 (URDF): where a joint that meets nothing ends."""


_REACH_SAMPLES = 9


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
    tangent = np.sqrt(np.maximum(dist**2 - reach**2, 0.0))
    phi_tangent = towards - np.arcsin(np.minimum(np.maximum(reach / safe, 0.0), 1.0))
    cos_tip = (dist**2 + length**2 - reach**2) / (2.0 * length * safe)
    phi_tip = towards - np.arccos(np.minimum(np.maximum(cos_tip, -1.0), 1.0))
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


_HEIGHTS = np.linspace(-0.04, 0.04, 9)
"""Heights (m) in the finger plane, from where the turned axis crosses it, at which a turned
object's section is measured (:func:`_reach`)."""


def _reach(radius_fn, along: np.ndarray, beta: np.ndarray) -> tuple[np.ndarray, ...]:
    """What the 9 mm capsules of each finger meet, batched (``patterns.reach_profile`` for a
    turned object): reach (..., 4), how far off the finger's plane the contact lies as a
    fraction of the pad (0 in the plane, 1 at the capsule's side), and the height (m) of the
    section's widest point above where the axis crosses the finger's plane.

    ``along`` (..., 4): each finger plane's distance from the object's centre along O-O';
    ``beta`` (..., 1): the rotation about the palm normal. The solid's points in the plane
    x = along + du (du across the pad) at height s above the centre lie u = x cos(beta) -
    s sin(beta) along its axis and w = x sin(beta) + s cos(beta) off it, so the section's
    half-width toward the palm is sqrt(r(u)^2 - w^2). Its widest point (refined by a parabola
    through the sampled heights) is taken as a circle's radius and centre: exact for a
    cylinder and for a sphere at any rotation, and for any solid unturned. On a steep profile
    (a torus near its ends) the widest point moves well away from the axis, the other way to
    the axis' own tilt."""
    cb, sb = np.cos(beta)[..., None, None], np.sin(beta)[..., None, None]
    x = along[..., None, None] + _DU[:, None]
    height = _HEIGHTS - along[..., None, None] * (sb / cb)
    u, w = x * cb - height * sb, x * sb + height * cb
    with np.errstate(invalid="ignore"):
        r = radius_fn(u)
    half2 = np.where(r > 0, r * r - w * w, 0.0)  # NaN (no such solid) counts as nothing there
    half = np.sqrt(np.maximum(half2, 0.0))
    grown = np.where(half > 0, half + _GROW[:, None], 0.0)
    flat = grown.reshape(grown.shape[:-2] + (-1,))
    best = flat.argmax(axis=-1)
    i_du, i_h = np.divmod(best, len(_HEIGHTS))
    row = np.take_along_axis(grown, i_du[..., None, None], -2)[..., 0, :]
    peak = np.take_along_axis(row, i_h[..., None], -1)[..., 0]
    inner = np.minimum(np.maximum(i_h, 1), len(_HEIGHTS) - 2)
    y0 = np.take_along_axis(row, (inner - 1)[..., None], -1)[..., 0]
    y2 = np.take_along_axis(row, (inner + 1)[..., None], -1)[..., 0]
    curve = y0 - 2.0 * peak + y2
    ok = (inner == i_h) & (curve < 0) & (y0 > 0) & (y2 > 0)
    shift = np.where(ok, 0.5 * (y0 - y2) / np.where(ok, curve, -1.0), 0.0)
    reach = np.where(ok, peak - 0.25 * (y0 - y2) * shift, peak)
    step = _HEIGHTS[1] - _HEIGHTS[0]
    rise = np.take_along_axis(height[..., 0, :], i_h[..., None], -1)[..., 0] + shift * step
    return reach, _SIDE[i_du], np.where(reach > 0, rise, 0.0)


_CLEARANCE_U = np.linspace(-0.3, 0.3, 301)
"""Where along the axis (m) the nominal depth samples the profile: ``scene.place_object``
samples it every 0.5 mm; every 2 mm moves the depth by less than 0.3 mm on these profiles
(their maxima lie at x = 0 or at a range end, both sampled)."""


@cache
def _scene_constants() -> tuple[tuple[tuple[float, float, float], ...], float, float]:
    from ..objects.placement import CLEARANCES, GRASP_Z, STANDOFF

    return tuple((lo, hi, depth) for (lo, hi), depth in CLEARANCES), STANDOFF, GRASP_Z


def nominal_centre(
    shape: Shape, params: Mapping[str, np.ndarray], rotation=0.0
) -> tuple[np.ndarray, float]:
    """(y, z) of the object's axis at zero offset, as ``scene.place_object`` puts it:
    STANDOFF clear of the palm and the open thumb, deeper for a larger object. ``rotation``
    (rad, broadcastable with the sizes) turns the axis about the palm normal, so the section
    at u along it lies at x = u cos(rotation) and a clearance window takes other sections."""
    windows, standoff, grasp_z = _scene_constants()
    sizes = {k: np.asarray(v, dtype=float) for k, v in params.items()}
    batch = np.broadcast_shapes(*(v.shape for v in sizes.values()), np.shape(rotation))
    cos = np.broadcast_to(np.cos(np.asarray(rotation, dtype=float)), batch)[..., None]
    stretch = 1.0 / float(np.min(cos, initial=1.0))  # a turned axis reaches the windows later
    lo_at = min(lo for lo, _, _ in windows) * stretch
    hi_at = max(hi for _, hi, _ in windows) * stretch
    u = _CLEARANCE_U[(_CLEARANCE_U >= lo_at - 1e-9) & (_CLEARANCE_U <= hi_at + 1e-9)]
    with np.errstate(invalid="ignore"):
        r = shape.radius(u, **{k: np.broadcast_to(v, batch)[..., None] for k, v in sizes.items()})
    r = np.where(r > 0, r, 0.0)
    x = u * cos
    y0 = np.zeros(batch)
    for lo, hi, depth in windows:
        inside = (x >= lo - 1e-9) & (x <= hi + 1e-9)
        y0 = np.minimum(y0, -depth - standoff - np.where(inside, r, 0.0).max(axis=-1))
    return y0, grasp_z


def _sections(shape: Shape, params: Mapping[str, np.ndarray], pose) -> tuple[np.ndarray, ...]:
    """What each finger meets, batched: reach and sideways fraction (..., 4), and the
    section's centre y (..., 1) and z (..., 4) in the finger plane. ``pose`` (..., 2 or 3):
    offset along O-O', offset along the fingers (m)[, rotation about the palm normal (rad)].
    Turned by beta, the axis crosses finger f's plane at z = z0 + dz - (x_f - dx) tan(beta)
    (``patterns.theoretical_angles``); the section's widest point lies off it (:func:`_reach`)."""
    reach, side, y0, z0, rise = _section_parts(shape, params, pose)
    return reach, side, y0, z0 + np.asarray(pose, dtype=float)[..., 1:2] + rise


def _section_parts(shape: Shape, params: Mapping[str, np.ndarray], pose) -> tuple:
    """:func:`_sections` before the offset along the fingers is added: reach, side, centre y,
    the nominal centre z (a float) and the widest point's rise. None of them depends on that
    offset, so points that differ only in it share them (the shape fit's search)."""
    pose = np.asarray(pose, dtype=float)
    beta = pose[..., 2:3] if pose.shape[-1] > 2 else np.zeros(pose.shape[:-1] + (1,))
    y0, z0 = nominal_centre(shape, params, beta[..., 0])
    sizes = {k: np.asarray(v, dtype=float)[..., None, None, None] for k, v in params.items()}
    reach, side, rise = _reach(lambda u: shape.radius(u, **sizes), _XF - pose[..., 0:1], beta)
    return reach, side, y0[..., None], z0, rise


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
    (along O-O', along the fingers) in m, or (..., 3) with the rotation (rad) last. A finger
    with no object under it gets J3 = 90 deg, J0 = 180 deg and sideways fraction -1. The
    distal capsule (8 mm) is taken to meet the section 1 mm further in than the others."""
    return _chain_features(*_sections(shape, params, offset))


# --- calibration ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Calibration:
    """Linear correction of the geometric model, per joint group (rows J3, J0) and finger.

    predicted = intercept + gain * geometric + side * sideways fraction (+ the family's
    offset), for fingers with the object under them (a finger that misses keeps its joint
    limits). ``sigma`` is the residual spread that weights each angle in the fit;
    ``loss_scale`` the soft-L1 knee (in sigmas); ``penalty`` the score added per size
    parameter. ``family`` maps a shape family to a (2, 4) offset (rad) added to its
    prediction: how far a hand squeezes past first contact depends on the surface it closes
    on in ways the planar finger chain does not see (on MuJoCo's hand J0 ends 7-11 deg short
    on hyperboloids and 10 deg past on spheres, ``benchmarks/calibration_residuals.py``); learnt
    from grasps of known objects (``hand_fit.py``), none for a family it does not name. The
    shipped coefficients have none.
    """

    intercept: np.ndarray = field(default_factory=lambda: np.zeros((2, 4)))
    gain: np.ndarray = field(default_factory=lambda: np.ones((2, 4)))
    side: np.ndarray = field(default_factory=lambda: np.zeros((2, 4)))
    sigma: np.ndarray = field(default_factory=lambda: np.array([[0.03] * 4, [0.1] * 4]))
    loss_scale: float = 2.0
    penalty: float = 0.0
    source: str = "defaults"
    family: Mapping[str, np.ndarray] = field(default_factory=dict)
    angles: str = "raw"
    """What the coefficients were fitted on: ``raw`` angles, or ``zeroed`` on the open hand
    (``calibrate --zeroed``): a reader that is not given robust-joints (the doubt cross-check)
    zeroes a record first where they are zeroed."""

    def __post_init__(self) -> None:
        for name in ("intercept", "gain", "side", "sigma"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (2, 4) or not np.all(np.isfinite(value)):
                raise UsageError(f"shape-fit calibration {name} must be 2 x 4 finite numbers")
            object.__setattr__(self, name, value)
        if not isinstance(self.family, Mapping):
            raise UsageError("shape-fit calibration family must map shape names to offsets")
        offsets = {}
        for name, value in self.family.items():
            try:
                value = np.asarray(value, dtype=float)
            except (TypeError, ValueError):
                value = np.empty(0)
            if not (isinstance(name, str) and value.shape == (2, 4)) or not np.all(
                np.isfinite(value)
            ):
                raise UsageError(f"shape-fit calibration family {name} must be 2 x 4 numbers")
            offsets[name] = value
        object.__setattr__(self, "family", offsets)
        if not np.all(self.sigma > 0):
            raise UsageError("shape-fit calibration sigma must be positive")
        if self.angles not in ("raw", "zeroed"):
            raise UsageError(f"shape-fit calibration angles: raw or zeroed, not {self.angles!r}")
        if not (self.loss_scale > 0 and np.isfinite(self.penalty) and self.penalty >= 0):
            raise UsageError("shape-fit calibration loss_scale must be > 0 and penalty >= 0")

    def apply(self, geometric: np.ndarray, family: str | None = None) -> np.ndarray:
        """(..., 3, 4) geometric features of shape ``family`` -> (..., 2, 4) predicted J3, J0
        (``family`` None, or one without an offset: the coefficients alone)."""
        angles, side = geometric[..., :2, :], geometric[..., 2:3, :]
        intercept = self.intercept
        if family in self.family:
            intercept = intercept + self.family[family]
        corrected = intercept + self.gain * angles + self.side * np.maximum(side, 0.0)
        return np.where(side >= 0, corrected, angles)

    def to_dict(self) -> dict:
        doc = {
            "intercept": self.intercept.tolist(),
            "gain": self.gain.tolist(),
            "side": self.side.tolist(),
            "sigma": self.sigma.tolist(),
            "loss_scale": self.loss_scale,
            "penalty": self.penalty,
        }
        if self.family:  # only then: the shipped file and older hand files read the same
            doc["family"] = {name: v.tolist() for name, v in self.family.items()}
        return doc

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
                family=doc.get("family", {}),
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


_ACTIVE: ContextVar[Calibration | None] = ContextVar("shape_fit_calibration", default=None)


def active_calibration() -> Calibration:
    """The coefficients the shape fit uses when a caller names none: a hand calibration put in
    force by :func:`use_calibration` (``tactile-bullet calibrate``'s file), else the shipped
    ones."""
    return _ACTIVE.get() or load_calibration()


def calibration_in_force() -> Calibration | None:
    """The hand calibration :func:`use_calibration` put in force, None where none is."""
    return _ACTIVE.get()


def use_own(calibration: Calibration | None):
    """:func:`use_calibration` of ``calibration`` where one is given (a hand's own, from
    ``realhand.hand_calibration.record_calibration``), else the coefficients in force left as
    they are: never the shipped ones over a hand calibration the user put in force."""
    return use_calibration(calibration) if calibration is not None else nullcontext()


@contextmanager
def use_calibration(calibration: Calibration | None) -> Iterator[None]:
    """Within the block, every shape fit that names no coefficients uses ``calibration`` (None:
    the shipped ones): the classifier, the doubt cross-check and the rotation estimate all reach
    the fit through code that does not pass coefficients along. A context variable, so a block
    in one thread (one streaming ``Identifier``) leaves the others as they were."""
    token = _ACTIVE.set(calibration)
    try:
        yield
    finally:
        _ACTIVE.reset(token)
