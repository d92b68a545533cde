"""Theoretical signatures and the training-free nearest-pattern identifier (thesis 2.3.1, 2.5).

Theory: a finger wrapped on a circle of radius r closes by theta = s / r in total (eq. 2.3),
and the angle between two phalanges on a circle equals the central angle of the arc between
them (thesis Appendix A). Two models turn a shape's radius profile r(x), sampled at each
finger's own x on O-O' (hand.FINGER_X), into joint angles:

- ``hand`` (default): the Shadow hand's own geometry. Each finger flexes about its knuckle
  (the LF knuckle sits 8.5 mm lower, the MF 4 mm higher) around the section of the object
  where the scene places it, grown by the phalanx radius; the proximal phalanx lies along the
  tangent from the knuckle and each later joint turns by the central angle between successive
  tangent points (:func:`hand_wrap_angles`). Far from the knuckle this is eq. 2.3 again; near
  it, J3 mostly says where the knuckle meets the object, which is what the simulated (and a
  real) hand does: this model predicts simulated J3 within a few hundredths of a radian on
  cylinders, where eq. 2.3 alone gets even the sign of the finger-to-finger differences wrong.
- ``arc``: eq. 2.3 alone, joint i turning by the central angle of phalanx i,
  2 atan(l_i / (2 (r + pad))), identical for every finger but for r.

Either way, the angles go through exactly the pipeline of measured ones
(``signature.signature_from_angles``).

Identification: dynamic time warping (dtaidistance's C implementation) between each enhanced
line and the pattern's (each shape's pattern taken at the size whose whole-finger level is
nearest the grasp's), summed over both lines; the nearest pattern wins if it lies within the
correspondence threshold, else "unknown"; between hyperboloid and cylinder the signature's
bulge (the thesis' integral rule) decides. Both thresholds come from simulated grasps
(``tools/invariance.py`` writes ``data/identification.json``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache
from importlib import resources

import numpy as np

from ..errors import UsageError
from ..hand import (
    FINGER_X,
    KNUCKLE_Z,
    LONG_FINGERS,
    PHALANX_LENGTHS,
)
from ..objects.shapes import BUILTIN_SHAPES, THESIS_SHAPES, Shape
from ..records import Pose
from .signature import Signature, signature_from_angles

PAD_RADIUS = 0.009
"""Distance (m) from a phalanx's axis to its pad: the sheet's phalanx capsule radius."""

JOINT_LIMIT = np.pi / 2
"""Where a finger that misses the object ends: each of J3, J2, J1 at 90 deg."""

DTW_WINDOW = 0.1
"""Sakoe-Chiba band as a fraction of the line length: fingers sit at fixed places on O-O', so a
warp of more than a tenth of the hand would match features no finger could have moved."""

INTEGRAL_PAIR = ("hyperboloid", "cylinder")
"""The two patterns the integral rule separates (thesis Fig. 2.22)."""

INTEGRAL_LINES = ("upper", "lower", "none")

_TABLE = {s.name: s for s in BUILTIN_SHAPES}


def _shape(shape: str | Shape) -> Shape:
    if isinstance(shape, Shape):
        return shape
    try:
        return _TABLE[shape]
    except KeyError:
        raise UsageError(f"unknown shape {shape!r} (shapes: {', '.join(_TABLE)})") from None


def arc_angles(radius) -> np.ndarray:
    """Joint angles (3, n) of fingers wrapped on circles of the given radii (m), eq. 2.3 alone:
    rows J3, J2, J1, each the central angle of its phalanx, 2 atan(l / (2 (r + pad))).
    Radius 0 means no object: joints at 90 deg."""
    r = _radii(radius)
    lengths = np.asarray(PHALANX_LENGTHS)[:, None]
    theta = 2.0 * np.arctan(lengths / (2.0 * (r[None, :] + PAD_RADIUS)))
    return np.where(r[None, :] > 0, theta, JOINT_LIMIT)


def _radii(radius) -> np.ndarray:
    r = np.asarray(radius, dtype=float)
    if r.ndim != 1 or not np.all(np.isfinite(r)) or np.any(r < 0):
        raise UsageError("radii must be a 1-D array of finite numbers >= 0 (m)")
    return r


def reach_profile(radius_fn, t, pad: float = PAD_RADIUS, samples: int = 41) -> np.ndarray:
    """Distance from the axis at which a phalanx axis in the plane through ``t`` (m along
    O-O') first meets the solid: the section of the solid grown by the phalanx radius,
    max over |u - t| <= pad of r(u) + sqrt(pad^2 - (u - t)^2); 0 where nothing is in reach.

    A capsule is as wide as its radius on each side of the finger's plane, so on a curved
    profile it touches where the solid is wider than at its own section: a finger at 33 mm
    on a 45 mm sphere meets it 43 mm from the axis, not r(x) + pad = 40 mm.
    """
    t = np.asarray(t, dtype=float)
    du = np.linspace(-pad, pad, samples)
    r = radius_fn(t[:, None] + du[None, :])
    grown = np.where(r > 0, r + np.sqrt(np.clip(pad**2 - du**2, 0.0, None))[None, :], 0.0)
    return grown.max(axis=1)


def hand_wrap_angles(radius, centre_y: float, centre_z=None, reach=None) -> np.ndarray:
    """Joint angles (3, 4) of the four long fingers wrapped on the object's cross-sections.

    Finger f flexes in its own plane x = FINGER_X[f] about its knuckle (y = 0, z = KNUCKLE_Z);
    the cross-section there is a circle of radius r_f centred at (centre_y, centre_z), which the
    phalanx axes meet at R = ``reach`` (default r_f + pad). The enclosure grasp ends with each
    phalanx tangent to that circle: the proximal one along the tangent from the knuckle (J3 =
    the tangent's direction, which is where the knuckle's height and the object's distance
    enter), and each joint after it turning by the central angle between successive tangent points,
    2 atan(e / R), e being how far the previous phalanx reaches past its own tangent point
    (Appendix A: the angle between phalanges equals the central angle of the arc between
    them). On a circle far from the knuckle this tends to eq. 2.3 (total s / R).
    """
    r = _radii(radius)
    if r.shape != (len(LONG_FINGERS),):
        raise UsageError("hand_wrap_angles needs one radius per long finger (ff, mf, rf, lf)")
    if centre_z is None:
        from ..objects.placement import GRASP_Z

        centre_z = GRASP_Z
    zc = np.broadcast_to(np.asarray(centre_z, dtype=float), r.shape)
    zk = np.array([KNUCKLE_Z[f] for f in LONG_FINGERS])
    big_r = r + PAD_RADIUS if reach is None else np.asarray(reach, dtype=float)
    # a finger with nothing in its plane (r = 0, reach 0: past a hemisphere's flat face) is
    # answered JOINT_LIMIT below; a unit stand-in keeps its arithmetic finite meanwhile
    big_r = np.where(r > 0, np.broadcast_to(big_r, r.shape), 1.0)
    vy, vz = centre_y - 0.0, zc - zk  # knuckle to centre, in the finger plane
    dist = np.hypot(vy, vz)
    towards = np.arctan2(-vy, vz)  # flexion that would point the finger at the centre
    theta1 = towards - np.arcsin(np.clip(big_r / dist, 0.0, 1.0))
    tangent = np.sqrt(np.clip(dist**2 - big_r**2, 0.0, None))
    l1, l2, _ = PHALANX_LENGTHS
    past1 = np.clip(l1 - tangent, 0.0, None)
    theta2 = 2.0 * np.arctan(past1 / big_r)
    past2 = np.clip(l2 - past1, 0.0, None)
    theta3 = 2.0 * np.arctan(past2 / big_r)
    theta = np.clip(np.stack([theta1, theta2, theta3]), 0.0, JOINT_LIMIT)
    return np.where(r[None, :] > 0, theta, JOINT_LIMIT)


MODELS = ("hand", "arc")
"""How theory turns r(x) into joint angles: ``hand`` (:func:`hand_wrap_angles`, the hand's own
knuckles and the object's nominal placement) or ``arc`` (:func:`arc_angles`, eq. 2.3 alone)."""


def theoretical_angles(
    shape: str | Shape,
    params: Mapping[str, float] | None = None,
    model: str = "hand",
    pose: Pose | None = None,
) -> np.ndarray:
    """(3, 4) joint angles a hand wrapped on ``shape`` would hold, the object placed where the
    scene puts it (``scene.place_object``: nominal depth, then the pose's offset and rotation).

    Turned by beta about the palm normal, the axis crosses finger f's plane at
    t = (x_f - dx) / cos(beta) along itself and at z_f = z0 - (x_f - dx) tan(beta): each
    finger sees its own section at its own height, which is what makes alpha grow with the
    rotation. The ``arc`` model ignores the pose (eq. 2.3 alone).
    """
    spec = _shape(shape)
    values = spec.resolve(params)
    pose = pose or Pose()
    x = np.array([FINGER_X[f] for f in LONG_FINGERS])
    if model == "arc":
        return arc_angles(spec.radius(x, **values))
    if model != "hand":
        raise UsageError(f"model must be one of {', '.join(MODELS)}, got {model!r}")
    from ..objects.placement import object_position

    centre = object_position(spec, values, pose)
    beta = pose.rotation
    if abs(beta) >= np.pi / 3:
        raise UsageError(f"rotation must be within +-60 deg, got {np.degrees(beta):.1f} deg")
    t = (x - centre[0]) / np.cos(beta)
    reach = reach_profile(lambda u: spec.radius(u, **values), t)
    z = centre[2] - (x - centre[0]) * np.tan(beta)
    return hand_wrap_angles(np.where(reach > 0, reach, 0.0), centre[1], z, reach)


def pattern(
    shape: str | Shape, params: Mapping[str, float] | None = None, model: str = "hand"
) -> Signature:
    """Theoretical signature of a shape (default sizes unless given)."""
    return signature_from_angles(theoretical_angles(shape, params, model))


@cache
def default_library(model: str = "hand") -> dict[str, Signature]:
    """Theoretical signatures of the five thesis shapes at their default sizes."""
    return {name: pattern(name, model=model) for name in THESIS_SHAPES}


FAMILY_SIZES = 6
"""Sizes per shape in a pattern family: every parameter at 0, 20, ..., 100% of its range."""


def pattern_family(
    shape: str | Shape, sizes: int = FAMILY_SIZES, model: str = "hand"
) -> tuple[Signature, ...]:
    """The shape's pattern at its default size and at ``sizes`` sizes across its ranges
    (every parameter at the same fraction; combinations the shape refuses are skipped)."""
    spec = _shape(shape)
    members = [pattern(spec, None, model)]
    for t in np.linspace(0.0, 1.0, sizes):
        params = {k: p.min + t * (p.max - p.min) for k, p in spec.params.items()}
        try:
            members.append(pattern(spec, params, model))
        except ValueError:
            continue
    return tuple(members)


@cache
def size_matched_library(model: str = "hand") -> dict[str, tuple[Signature, ...]]:
    """Pattern families of the five thesis shapes: :func:`identify`'s default library."""
    return {name: pattern_family(name, model=model) for name in THESIS_SHAPES}


def closest_in_size(signature: Signature, family) -> Signature:
    """The member of a pattern family whose whole-finger level (mean raw upper line, grey
    levels) is nearest the signature's: the theory at the size the hand felt.

    The enhancement removes size, but the hand's own tilt (knuckle heights) does not scale
    with it, so the normalised pattern of a small cylinder differs from a large one's;
    matching the level picks the right one without knowing the size.
    """
    if isinstance(family, Signature):
        return family
    members = tuple(family)
    if not members:
        raise UsageError("a pattern family is empty")
    level = float(np.mean(signature.raw_upper))
    return min(members, key=lambda m: abs(float(np.mean(m.raw_upper)) - level))


def dtw_distance(a, b, window: float = DTW_WINDOW) -> float:
    """DTW distance between two lines (Euclidean DTW, dtaidistance; C path when compiled)."""
    from dtaidistance import dtw

    x = np.ascontiguousarray(a, dtype=np.double)
    y = np.ascontiguousarray(b, dtype=np.double)
    band = max(1, int(round(window * max(x.size, y.size))))
    # No pruning: with it (the default) dtaidistance 2.5.1 returned inf for ordinary pairs.
    return float(dtw.distance_fast(x, y, window=band, use_pruning=False))


def signature_distance(sig: Signature, ref: Signature, window: float = DTW_WINDOW) -> float:
    """Distance between two signatures: DTW of the lower lines plus DTW of the upper lines."""
    return dtw_distance(sig.lower, ref.lower, window) + dtw_distance(sig.upper, ref.upper, window)


@dataclass(frozen=True)
class Thresholds:
    """Identification thresholds and where they came from."""

    correspondence: float = float("inf")
    """Largest distance to the nearest pattern that still counts as a match."""
    integral: float = 0.0
    """Bulge above which a hyperboloid/cylinder match is a hyperboloid."""
    integral_line: str = "upper"
    """Whose bulge the integral rule reads: "upper" (the whole finger's angle, eq. 2.3's
    quantity), "lower" (J3 alone) or "none" (rule off, nearest pattern only).
    ``tools/invariance.py`` keeps whichever splits the simulated grasps best."""
    source: str = "defaults"

    def __post_init__(self) -> None:
        if self.integral_line not in INTEGRAL_LINES:
            raise UsageError(
                f"integral_line must be one of {', '.join(INTEGRAL_LINES)}, "
                f"got {self.integral_line!r}"
            )


@cache
def _identification_data() -> dict:
    """``data/identification.json`` as written by ``tools/invariance.py`` ({} when absent)."""
    try:
        text = resources.files("tactile_bullet").joinpath("data/identification.json").read_text()
    except (FileNotFoundError, OSError):
        return {}
    return json.loads(text)


def load_thresholds() -> Thresholds:
    """Thresholds measured by ``tools/invariance.py`` (package data), or the defaults."""
    doc = _identification_data()
    if not doc:
        return Thresholds()
    return Thresholds(
        correspondence=float(doc["correspondence_threshold"]),
        integral=float(doc["integral_threshold"]),
        integral_line=str(doc.get("integral_line", "upper")),
        source="data/identification.json",
    )


def identification_ranges() -> dict[str, dict[str, tuple[float, float]]]:
    """Per thesis shape, the sizes (m, per parameter) inside which training-free identification
    held for at least 90% of the grasps over ``tools/invariance.py``'s grid of offsets: the
    analogue of thesis Table 2.2. Kept beside the shapes' valid ranges rather than written
    over them, because for the sphere and cylinder it is a single size, and every other
    feature (training, the demo) needs the full ranges. Shapes without such sizes are absent."""
    ranges = _identification_data().get("identification_ranges", {})
    return {
        shape: {k: (float(lo), float(hi)) for k, (lo, hi) in params.items()}
        for shape, params in ranges.items()
    }


def in_identification_range(shape: str, params: Mapping[str, float]) -> bool:
    """Whether sizes ``params`` of ``shape`` lie where training-free identification holds."""
    ranges = identification_ranges().get(shape)
    if not ranges:
        return False
    return all(lo - 1e-9 <= float(params[k]) <= hi + 1e-9 for k, (lo, hi) in ranges.items())


@dataclass(frozen=True)
class Identification:
    """Outcome of :func:`identify`: the decided name, the nearest pattern and every distance."""

    name: str
    nearest: str
    distances: dict[str, float] = field(default_factory=dict)
    bulge: float = 0.0
    """The bulge the integral rule read (upper line when the rule is off)."""
    integral_rule: bool = False
    """True when the integral rule chose between hyperboloid and cylinder."""


def identify(
    signature: Signature,
    library: Mapping[str, Signature | Sequence[Signature]] | None = None,
    thresholds: Thresholds | None = None,
) -> Identification:
    """Nearest theoretical pattern by DTW, "unknown" beyond the correspondence threshold.

    ``library`` maps a shape to one pattern (default: :func:`default_library`, the thesis'
    one pattern per shape) or to a family of patterns at several sizes
    (:func:`size_matched_library`, what ``signature_summary`` uses), of which the one nearest
    in level is compared.
    """
    lib = default_library() if library is None else library
    if not lib:
        raise UsageError("the pattern library is empty")
    th = load_thresholds() if thresholds is None else thresholds
    distances = {
        name: signature_distance(signature, closest_in_size(signature, ref))
        for name, ref in lib.items()
    }
    nearest = min(distances, key=distances.__getitem__)
    name, ruled = nearest, False
    line = th.integral_line
    bulge = signature.bulge_lower if line == "lower" else signature.bulge_upper
    if line != "none" and nearest in INTEGRAL_PAIR and all(n in lib for n in INTEGRAL_PAIR):
        name = INTEGRAL_PAIR[0] if bulge > th.integral else INTEGRAL_PAIR[1]
        ruled = True
    if distances[nearest] > th.correspondence:
        name = "unknown"
    return Identification(name, nearest, distances, bulge, ruled)
