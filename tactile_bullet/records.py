"""Plain data: object pose, controller settings and the GraspRecord a grasp produces.

Frozen dataclasses holding numpy arrays; behaviour lives in functions elsewhere. A record
round-trips through ``.npz`` without pickle (metadata as a JSON string), so loading a record
never runs code from the file.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import UsageError
from .hand import FCI_JOINTS, FINGERS, JOINT_NAMES, LONG_FINGERS

RECORD_FORMAT = 1
SOURCES: tuple[str, ...] = ("simulated", "recorded")
"""Where a record came from: the simulator, or a real hand's recording (realhand/recordings.py)."""

MAX_OFFSET_M = 1.0
"""Largest object offset (m) along any palm axis: a metre is far beyond the hand's reach (an
object there touches nothing), and larger numbers only reach PyBullet as float overflow."""
MAX_ROTATION_DEG = 90.0
"""Largest object rotation about the palm normal (deg), either way: the CLI's bound and every
sweep's (a quarter turn is the thesis' largest, the 90-deg classes of chapter 4)."""
MAX_TIME_S = 60.0
"""Longest simulated grasp (s): the enclosure grasp ends in 1-3 s; a longer limit only grows
the time series a record holds."""
MAX_SETTLE_STEPS = 10_000
RECORD_ARRAYS = ("time", "angles", "efforts", "final_angles", "contact_link",
                 "contact_position", "contact_normal", "contact_force")  # fmt: skip
"""The arrays a record is saved with (:meth:`GraspRecord.arrays`): a record file or shard
holding any other member is refused, not read."""
RECORD_MEMBER_LIMIT = 256 << 20
"""The most bytes one saved array may decompress to (a simulated grasp's series are ~1 MB):
a zip bomb is refused before it is inflated."""


@dataclass(frozen=True)
class Pose:
    """Where the object sits relative to the grasp centre.

    ``offset`` (m) is (x along O-O', y along the palm normal, positive toward the palm,
    z along the fingers) in the palm frame; ``rotation`` (rad) turns the object about the palm
    normal (the palm's y axis), the thesis' alpha.
    """

    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: float = 0.0

    def __post_init__(self) -> None:
        off = tuple(float(v) for v in self.offset)
        if len(off) != 3 or not all(math.isfinite(v) for v in off):
            raise UsageError(f"offset must be three finite numbers in metres, got {self.offset}")
        if any(abs(v) > MAX_OFFSET_M for v in off):
            raise UsageError(
                f"offset {off} m is out of range: each coordinate within +-{MAX_OFFSET_M:g} m"
            )
        if not math.isfinite(float(self.rotation)):
            raise UsageError(f"rotation must be finite, got {self.rotation}")
        if abs(math.degrees(float(self.rotation))) > MAX_ROTATION_DEG + 1e-9:
            raise UsageError(
                f"rotation {math.degrees(float(self.rotation)):g} deg is out of range "
                f"[-{MAX_ROTATION_DEG:g}, {MAX_ROTATION_DEG:g}] degrees"
            )
        object.__setattr__(self, "offset", off)
        object.__setattr__(self, "rotation", float(self.rotation))


@dataclass(frozen=True)
class ControllerSettings:
    """Algorithm 1 parameters.

    mode: "torque" stops a joint when the effort on it or a joint downstream exceeds
    ``thres_t``; "contact" when a phalanx at or downstream of it touches the object.
    delta: joint-target increment per control tick (rad); with ``control_every`` physics
    steps of ``timestep`` per tick this sets the closing speed (default 1.44 rad/s at 240 Hz,
    under the Shadow hand's 2 rad/s; at 0.015 rad per tick the contacts turn unstable).
    thres_t: N m on the damping-compensated, low-passed joint effort (sim/grasp.py).
    """

    mode: str = "torque"
    delta: float = 0.006
    thres_t: float = 0.35
    max_time: float = 4.0
    timestep: float = 1.0 / 240.0
    control_every: int = 1
    sample_rate: float = 60.0
    motor_force: float = 1.0
    settle_steps: int = 10
    preshape: bool = False
    """Start each finger's J3 where its sweep comes within 5 mm of the object (collision
    queries) instead of driving it there through free space: 1.2x faster, final angles within
    ~2.5 deg in torque mode, but that shift costs the signature accuracy on cylinder vs
    hyperboloid (``tactile-bullet demo``: 96.7% -> 85.0%), so it is off by default. The thumb
    always skips its free sweep, which leaves the long fingers' angles unchanged."""
    early_stop: bool = False
    """Stop closing a finger as soon as the dynamic non-contact detector
    (``perception/temporal.py``, thesis ch. 3) finds it out of contact, instead of running it to
    its joint limits: fewer physics steps where a finger misses the object, identical grasps
    where none does. Off by default (records saved before it existed load with it off)."""
    friction: float = 0.8
    """Lateral (Coulomb) friction coefficient of the hand's links and the object. A physics
    knob, not Algorithm 1's: the benchmark's simulator-shift protocol varies it."""
    phalanx_scale: float = 1.0
    """Length factor of every finger's and the thumb's phalanges (joint spacing and link
    geometry): 1.03 is another hand of the same model with 3% longer fingers."""
    coupling: str = "j2-first"
    """How the J0 tendon shares its travel between J2 and J1 (``sim/coupling.py``): "j2-first"
    (the thesis' hand), "equal-torque" or "distal-first"."""
    joint_offsets: tuple[float, ...] = ()
    """Calibration offsets (rad) added to the recorded angles of the 12 FCI joints, in
    :data:`OFFSET_JOINTS` order: what an uncalibrated real hand's sensors report. Empty: none."""
    contact_stiffness: float = 0.0
    """Contact stiffness (N/m) between the hand and the object, a soft fingertip's; 0: the
    engine's rigid contact."""
    engine: str = "bullet"
    """The physics engine (``sim/engines/``, the ``register_engines`` hook): ``bullet`` or
    ``mujoco`` built in. Left out of saved records while ``bullet``, so older records and
    datasets stay byte-identical and resumable."""
    tendon_spring: float = 0.0
    """Return spring (N m/rad) on each long finger's distal joint J1, in an engine whose tendon
    splits J0 = J1 + J2 by its physics (``Engine.tendon``: ``mujoco``): 0 leaves the split to
    the tendon's own dynamics (the distal joint closes first), about 0.3 holds J1 back until the
    middle phalanx meets the object (the thesis' J2-first hand), 1 keeps J1 under about 20 deg.
    What a real hand's tendon varies in; engines that split J0 by ``coupling`` refuse it."""
    servo_stiffness: float = 0.0
    """Stiffness (N m/rad) of the long fingers' position servos (J4, J3 and the J0 tendon), in
    an engine whose servos are springs (``mujoco``); 0 keeps the hand model's own (ours: 20).
    A soft servo yields after its stage: at 1 (the MuJoCo Menagerie hand's value) our hand's
    J3 ends 10-12 deg more open on a 45 mm sphere, when the tendon squeezes. Bullet's motors
    are constraints with a force limit, not springs, and refuse it."""
    hand_model: str | None = None
    """Another MJCF model of the Shadow hand for the ``mujoco`` engine (``--hand-model``, an
    absolute path; docs/engines.md lists what it must have). None: the project's own."""
    hand_model_digest: str | None = None
    """sha256 of ``hand_model``'s content and of every file it includes or references
    (``mujoco_hand.model_digest``), taken when the settings were made: a grasp refuses a model
    that changed since, and ``generate --resume`` refuses to mix two hands."""

    def __post_init__(self) -> None:
        if self.mode not in ("torque", "contact"):
            raise UsageError(f"mode must be 'torque' or 'contact', got {self.mode!r}")
        for name in ("delta", "thres_t", "max_time", "timestep", "sample_rate", "motor_force",
                     "friction"):  # fmt: skip
            value = getattr(self, name)
            if isinstance(value, bool) or not (
                isinstance(value, int | float) and math.isfinite(value) and value > 0
            ):  # a boolean is no number, though Python counts True as 1
                raise UsageError(f"controller {name} must be a positive number, got {value!r}")
        if not MIN_DELTA <= self.delta <= 0.2:  # 1e-300 made the thumb's sweep 1e300 ticks
            raise UsageError(f"controller delta {self.delta} rad per tick is out of range "
                             f"({MIN_DELTA:g} to 0.2)")  # fmt: skip
        if self.thres_t > 2.0 * self.motor_force:  # 1e9 ran every grasp to max_time
            raise UsageError(f"controller thres_t {self.thres_t:g} N m is above the strongest "
                             f"finger motor's torque ({2.0 * self.motor_force:g} N m, twice "
                             "motor_force): no joint could reach it")  # fmt: skip
        for flag in ("preshape", "early_stop"):
            if not isinstance(getattr(self, flag), bool | np.bool_):
                raise UsageError(
                    f"controller {flag} must be true or false, got {getattr(self, flag)!r}"
                )
        for name in ("control_every", "settle_steps"):
            value = getattr(self, name)
            if not isinstance(value, int | np.integer) or isinstance(value, bool):
                raise UsageError(f"controller {name} must be an integer, got {value!r}")
        if int(self.control_every) < 1 or int(self.settle_steps) < 0:
            raise UsageError("control_every must be >= 1 and settle_steps >= 0")
        if self.max_time > MAX_TIME_S or self.settle_steps > MAX_SETTLE_STEPS:
            raise UsageError(
                f"controller max_time must be at most {MAX_TIME_S:g} s and settle_steps at "
                f"most {MAX_SETTLE_STEPS}, got {self.max_time!r} and {self.settle_steps!r}"
            )
        if self.timestep > 0.01 or self.sample_rate > 1.0 / self.timestep:
            raise UsageError(
                f"controller timestep must be at most 0.01 s and sample_rate at most one "
                f"sample per step, got {self.timestep!r} s and {self.sample_rate!r} Hz"
            )
        if not isinstance(self.engine, str) or not self.engine:
            raise UsageError(f"controller engine must be an engine name, got {self.engine!r}")
        if self.hand_model is not None and not isinstance(self.hand_model, str):
            raise UsageError(f"controller hand_model must be a file path, got {self.hand_model!r}")
        digest = self.hand_model_digest
        if digest is not None and not (
            isinstance(digest, str) and len(digest) == 64
            and all(c in "0123456789abcdef" for c in digest) and self.hand_model is not None
        ):  # fmt: skip
            raise UsageError(
                f"controller hand_model_digest must be a hand model's sha256 (64 hex digits, "
                f"with hand_model), got {digest!r}"
            )
        scale = self.phalanx_scale
        if isinstance(scale, bool) or not isinstance(scale, int | float) or not 0.8 <= scale <= 1.2:
            raise UsageError(f"controller phalanx_scale must be from 0.8 to 1.2, got {scale!r}")
        _check_variation(self)


MIN_DELTA = 1e-4
"""Smallest target step (rad per tick): at 240 Hz a joint's 90 deg take 65 s, past max_time."""
COUPLINGS: tuple[str, ...] = ("j2-first", "equal-torque", "distal-first")
"""The J1/J2 tendon rules ``sim/coupling.py`` implements (``ControllerSettings.coupling``)."""
OFFSET_JOINTS: tuple[str, ...] = tuple(j for f in LONG_FINGERS for j in FCI_JOINTS[f])
"""The joints ``ControllerSettings.joint_offsets`` applies to: ff J3, J2, J1, then mf, rf, lf."""
MAX_JOINT_OFFSET = math.radians(20.0)
"""Largest calibration offset (rad) a record may carry: beyond it a reading is not a joint's."""
MAX_CONTACT_STIFFNESS = 1e7
MAX_SERVO_STIFFNESS = 1000.0
"""Stiffest finger servo (N m/rad) a record may carry (our MJCF's is 20)."""
MAX_TENDON_SPRING = 5.0
"""Stiffest distal return spring (N m/rad) a record may carry: at 5 the spring alone reaches
the stop threshold 0.35 N m within 4 deg of J1, so J1 no longer moves at all."""


def _check_variation(ctl: ControllerSettings) -> None:
    """The hand-variation fields (coupling, offsets, contact stiffness), normalised in place."""
    if ctl.coupling not in COUPLINGS:
        raise UsageError(
            f"controller coupling must be one of {', '.join(COUPLINGS)}, got {ctl.coupling!r}"
        )
    offsets = ctl.joint_offsets
    if isinstance(offsets, np.ndarray) and offsets.ndim == 1:
        offsets = offsets.tolist()
    if isinstance(offsets, str) or not isinstance(offsets, tuple | list):
        raise UsageError(f"controller joint_offsets must be a list of numbers, got {offsets!r}")
    if offsets and len(offsets) != len(OFFSET_JOINTS):
        raise UsageError(
            f"controller joint_offsets needs {len(OFFSET_JOINTS)} values (rad, in the order "
            f"{', '.join(OFFSET_JOINTS)}), got {len(offsets)}"
        )
    for v in offsets:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or (
            abs(v) > MAX_JOINT_OFFSET
        ):
            raise UsageError(
                f"controller joint_offsets must be finite numbers within +-"
                f"{math.degrees(MAX_JOINT_OFFSET):g} deg (in rad), got {v!r}"
            )
    object.__setattr__(ctl, "joint_offsets", tuple(float(v) for v in offsets))
    for name, top, zero, unit in (
        ("contact_stiffness", MAX_CONTACT_STIFFNESS, "rigid", "N/m"),
        ("tendon_spring", MAX_TENDON_SPRING, "none", "N m/rad"),
        ("servo_stiffness", MAX_SERVO_STIFFNESS, "the model's own", "N m/rad"),
    ):
        k = getattr(ctl, name)
        if isinstance(k, bool) or not isinstance(k, int | float) or not 0 <= k <= top:
            raise UsageError(
                f"controller {name} must be from 0 ({zero}) to {top:g} {unit}, got {k!r}"
            )
    for name in ("tendon_spring", "servo_stiffness"):
        if getattr(ctl, name) > 0 and ctl.engine == "bullet":
            raise UsageError(
                f"controller {name} is a mujoco knob: bullet splits J0 by coupling and its "
                "motors are constraints, not springs"
            )


PHYSICS_DEFAULTS: dict[str, float | bool | str | tuple | None] = {
    "friction": 0.8,
    "phalanx_scale": 1.0,
    "early_stop": False,
    "coupling": "j2-first",
    "joint_offsets": (),
    "contact_stiffness": 0.0,
    "engine": "bullet",
    "hand_model": None,
    "hand_model_digest": None,
    "tendon_spring": 0.0,
    "servo_stiffness": 0.0,
}
"""Fields of ControllerSettings added after records were first written (physics knobs and
the early grasp end): left out of the saved form while at these values, so older records,
dataset manifests (compared on ``--resume``) and their checksums stay byte-identical."""


def controller_dict(controller: ControllerSettings) -> dict:
    """The settings as saved in records and manifests (see :data:`PHYSICS_DEFAULTS`)."""
    out = asdict(controller)
    for key, default in PHYSICS_DEFAULTS.items():
        if out[key] == default:
            del out[key]
    if "joint_offsets" in out:
        out["joint_offsets"] = list(out["joint_offsets"])
    return out


@dataclass(frozen=True, eq=False)
class GraspRecord:
    """Everything one grasp produced.

    Time series are sampled at ``controller.sample_rate``; columns follow ``joint_names``.
    Contacts are those present at the end of the grasp, in the palm frame: position on the
    object, the object's outward normal there, and the normal force (N). ``contact_link`` holds
    the hand link name of each contact. Units: s, rad, N m, m, N.

    ``source`` is "simulated" or "recorded" (a real hand's joint states, read by
    ``realhand/recordings.py``: no contacts, pose and controller unknown, ``shape`` the user's
    label or "unknown").
    """

    shape: str
    params: Mapping[str, float]
    pose: Pose
    controller: ControllerSettings
    seed: int
    time: np.ndarray
    angles: np.ndarray
    efforts: np.ndarray
    final_angles: np.ndarray
    contact_link: np.ndarray
    contact_position: np.ndarray
    contact_normal: np.ndarray
    contact_force: np.ndarray
    fingers_in_contact: tuple[str, ...]
    flags: tuple[str, ...] = ()
    steps: int = 0
    joint_names: tuple[str, ...] = field(default=JOINT_NAMES)
    source: str = "simulated"
    mesh: Mapping[str, Any] | None = None
    """For a grasp on a mesh file: which one (``meshes.MeshSource.to_dict``: path, sha256,
    name, unit, scale, axis, budget), enough to find it again in the cache and re-simulate."""

    def __post_init__(self) -> None:
        if self.source not in SOURCES:
            raise UsageError(
                f"record source must be one of {', '.join(SOURCES)}, got {self.source!r}"
            )
        if self.source == "simulated" and (why := not_finite(self)):
            raise UsageError(why)  # a recording's are checked, joint by joint, as it is read

    @property
    def sim_time_s(self) -> float:
        return self.steps * self.controller.timestep

    def joint_index(self, name: str) -> int:
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise UsageError(f"record has no joint {name!r}") from None

    def final(self, name: str) -> float:
        """Final angle of one joint (rad)."""
        return float(self.final_angles[self.joint_index(name)])

    def final_dict(self) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.joint_names, self.final_angles, strict=True)}

    def fci_angles(self) -> np.ndarray:
        """Final (3, 4) joint angles for the FCI: rows J3, J2, J1; columns ff, mf, rf, lf."""
        idx = [[self.joint_index(FCI_JOINTS[f][row]) for f in LONG_FINGERS] for row in range(3)]
        return self.final_angles[np.array(idx)]

    def fci_series(self) -> np.ndarray:
        """(T, 3, 4) FCI angles over time: the input of the temporal image G."""
        idx = [[self.joint_index(FCI_JOINTS[f][row]) for f in LONG_FINGERS] for row in range(3)]
        return self.angles[:, np.array(idx)]

    def finger_contacts(self, finger: str) -> np.ndarray:
        """Boolean mask of the contacts on one finger's links."""
        from .hand import FINGER_LINKS

        return np.isin(self.contact_link, FINGER_LINKS[finger])

    def metadata(self) -> dict:
        """JSON-ready metadata; ``source`` appears only for recorded grasps, so simulated
        records (and datasets) stay byte-identical to those written before it existed."""
        meta = {
            "format": RECORD_FORMAT,
            "shape": self.shape,
            "params": dict(self.params),
            "pose": asdict(self.pose),
            "controller": controller_dict(self.controller),
            "seed": int(self.seed),
            "fingers_in_contact": list(self.fingers_in_contact),
            "flags": list(self.flags),
            "steps": int(self.steps),
            "joint_names": list(self.joint_names),
        }
        if self.source != "simulated":
            meta["source"] = self.source
        if self.mesh:
            meta["mesh"] = dict(self.mesh)
        return meta

    def arrays(self) -> dict[str, np.ndarray]:
        return {
            "time": self.time,
            "angles": self.angles,
            "efforts": self.efforts,
            "final_angles": self.final_angles,
            "contact_link": np.asarray(self.contact_link, dtype="U16"),
            "contact_position": self.contact_position,
            "contact_normal": self.contact_normal,
            "contact_force": self.contact_force,
        }

    def equals(self, other: GraspRecord) -> bool:
        """Bit-identical content (metadata and every array)."""
        if self.metadata() != other.metadata():
            return False
        a, b = self.arrays(), other.arrays()
        return all(np.array_equal(a[k], b[k]) for k in a)


FINITE_ARRAYS: tuple[str, ...] = (
    "time", "angles", "efforts", "final_angles", "contact_position", "contact_normal",
    "contact_force",
)  # fmt: skip
"""The arrays of a record that must hold finite numbers only."""


def not_finite(record: GraspRecord) -> str | None:
    """Why a record's numbers cannot be a grasp's (the first array holding NaN or an
    infinity: physics that went wrong, e.g. a hand model's ``kp="nan"``), or None. Such a grasp
    is a failed grasp with this reason, never a record: simulated, saved or loaded."""
    for name in FINITE_ARRAYS:
        values = np.asarray(getattr(record, name))
        if values.dtype.kind in "fc" and not np.all(np.isfinite(values)):
            what = name.replace("_", " ")
            if record.source != "simulated":
                return f"the recording's {what} hold NaN or infinity: not a grasp's readings"
            return (f"the grasp's {what} are not finite (NaN or infinite): its physics went "
                    "wrong (a hand model's gains, masses or limits?); not a grasp")  # fmt: skip
    return None


def record_from_parts(meta: Mapping, arrays: Mapping[str, np.ndarray]) -> GraspRecord:
    """Rebuild a record from ``metadata()`` and ``arrays()`` (as saved), validating both."""
    try:
        if int(meta["format"]) != RECORD_FORMAT:
            raise UsageError(f"record format {meta['format']} is not supported")
        pose = Pose(tuple(meta["pose"]["offset"]), meta["pose"]["rotation"])
        controller = ControllerSettings(**meta["controller"])
        record = GraspRecord(
            shape=str(meta["shape"]),
            params={k: float(v) for k, v in meta["params"].items()},
            pose=pose,
            controller=controller,
            seed=int(meta["seed"]),
            time=np.asarray(arrays["time"], float),
            angles=np.asarray(arrays["angles"], float),
            efforts=np.asarray(arrays["efforts"], float),
            final_angles=np.asarray(arrays["final_angles"], float),
            contact_link=np.asarray(arrays["contact_link"]).astype(str),
            contact_position=np.asarray(arrays["contact_position"], float).reshape(-1, 3),
            contact_normal=np.asarray(arrays["contact_normal"], float).reshape(-1, 3),
            contact_force=np.asarray(arrays["contact_force"], float),
            fingers_in_contact=tuple(f for f in meta["fingers_in_contact"] if f in FINGERS),
            flags=tuple(meta["flags"]),
            steps=int(meta["steps"]),
            joint_names=tuple(meta["joint_names"]),
            source=str(meta.get("source", "simulated")),
            mesh=dict(meta["mesh"]) if meta.get("mesh") else None,
        )
    except UsageError:
        raise
    except (KeyError, TypeError, ValueError) as exc:
        raise UsageError(f"not a valid grasp record ({type(exc).__name__}: {exc})") from None
    if why := not_finite(record):  # a saved recording's too
        raise UsageError(why)
    return record


def save_record(record: GraspRecord, path: str | Path) -> Path:
    """Write a record as ``.npz`` atomically (temporary file then rename)."""
    from .files import atomic_path

    path = Path(path)
    with atomic_path(path, "record") as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, meta=np.array(json.dumps(record.metadata())), **record.arrays())
    return path


def load_record(path: str | Path) -> GraspRecord:
    """Read a record written by :func:`save_record` (never unpickles)."""
    import zipfile
    import zlib

    from .files import check_npz_members, input_path

    path = Path(path)
    input_path(path, "record file")
    try:
        check_npz_members(path, str(path), lambda n: n == "meta" or n in RECORD_ARRAYS,
                          RECORD_MEMBER_LIMIT)  # fmt: skip
    except UsageError as exc:
        why = str(exc).removeprefix(f"{path} ")
        raise UsageError(f"{path} is not a readable grasp record ({why})") from None
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {k: data[k] for k in data.files if k != "meta"}
    except FileNotFoundError:
        raise UsageError(f"record file {path} does not exist") from None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        # a truncated or damaged file (BadZipFile, EOFError, zlib.error) is bad input too
        from .files import load_failure

        raise UsageError(f"{path} is not a readable grasp record ({load_failure(exc)})") from None
    try:
        return record_from_parts(meta, arrays)
    except UsageError as exc:
        raise UsageError(f"{path}: {exc}") from None
