"""The ``mujoco`` engine: the project's hand as MJCF (``urdf/shadow_hand.xml``, written by
``tools/make_mjcf.py`` from the same sheet as the URDF) and a static object, in MuJoCo.

What differs from ``bullet``, on purpose: J1 and J2 of each long finger are coupled by a fixed
tendon (J0 = J1 + J2) driven by one position actuator, as the real hand's tendon, so the split
of J0 between the two joints is the physics' (the controller sends their sum); the efforts of
J2 and J1 are that actuator's force. One controller tick (``ControllerSettings.timestep``)
is :data:`SUBSTEPS` MuJoCo steps taken in one call.
"""

from __future__ import annotations

import copy
import functools
import math
import os
import time
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import SimpleNamespace
from typing import NamedTuple

import numpy as np

from ...errors import UsageError
from ...hand import FINGER_LINKS, JOINT_NAMES, LONG_FINGERS
from ...objects.placement import object_position
from ...objects.shapes import Shape
from ...records import ControllerSettings, Pose
from .base import Contact, Engine
from .bullet import SWEEP_CLEARANCE, SWEEP_POSES
from .mujoco_cache import compiled_model
from .mujoco_hand import REQUIRED_ACTUATORS, load_hand_spec, mjcf_path, name_map, shadow_name
from .mujoco_objects import object_geoms

SUBSTEPS = 2
"""MuJoCo steps per controller tick: 2.08 ms at the default 240 Hz tick."""

OBJECT_BODY = "tactile_bullet_object"
ALL_BITS = (1 << 31) - 1


@functools.lru_cache(maxsize=4)
def _hand_xml(path: str) -> str:
    return Path(path).read_text()


class MujocoEngine(Engine):
    """Algorithm 1's view of one MuJoCo model: the hand plus one static object."""

    name = "mujoco"
    tendon = True

    def __init__(
        self,
        shape: Shape,
        params: Mapping[str, float],
        pose: Pose,
        controller: ControllerSettings,
        *,
        gui: bool = False,
        visual: bool = False,
        hand_model: str | Path | None = None,
    ) -> None:
        if gui:
            raise UsageError("--gui shows PyBullet's window: use it with --engine bullet")
        if controller.contact_stiffness > 0:
            # Tried as MuJoCo's direct stiffness over a 30 g fingertip mass: at 3e4 N/m the
            # fingers went through the object at 2 ms steps, and MuJoCo's own default contact
            # (20 ms time constant) is softer than 3e3 N/m would be, so the knob has no
            # faithful counterpart here yet.
            raise UsageError("contact_stiffness (a soft contact) is the bullet engine's only")
        if visual and "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
            os.environ["MUJOCO_GL"] = "egl"  # headless rendering; read when mujoco is imported
        import mujoco

        self._mj = mujoco
        proto = _prototype(shape, params, controller, hand_model or controller.hand_model)
        self.__dict__.update(proto.index)
        self._proto = proto
        if proto.spare:  # a finished grasp's model and data: no copy, no allocation
            m, d = proto.spare.pop()
            m.actuator_forcerange[:] = proto.model.actuator_forcerange  # the grasp set them
            m.jnt_stiffness[:] = proto.model.jnt_stiffness  # an earlier grasp's tendon spring
            m.actuator_gainprm[:] = proto.model.actuator_gainprm  # and its servo stiffness
            m.actuator_biasprm[:] = proto.model.actuator_biasprm
            mujoco.mj_resetData(m, d)
        else:  # the grasp changes force limits and the object's pose: a copy
            m = copy.copy(proto.model)
            d = mujoco.MjData(m)
        self.model = m
        position = np.asarray(object_position(shape, params, pose), float)
        half = pose.rotation / 2  # about the palm normal (y), as the bullet engine turns it
        quat = np.array([math.cos(half), 0.0, math.sin(half), 0.0])
        if self._palm is not None:  # another model's palm is not the world frame
            palm_pos, palm_rot, palm_quat = self._palm
            position = palm_pos + palm_rot @ position
            turned = np.zeros(4)
            mujoco.mju_mulQuat(turned, palm_quat, quat)
            quat = turned
        m.body_pos[self._object_body] = position
        m.body_quat[self._object_body] = quat
        m.geom_friction[:, 0] = controller.friction
        # The distal return spring (ControllerSettings.tendon_spring), about J1's zero, on top
        # of any stiffness the model gives J1 itself.
        m.jnt_stiffness[self._distal_joints] += controller.tendon_spring
        if controller.servo_stiffness > 0:  # a position servo: force = kp (target - q) - kv q'
            m.actuator_gainprm[self._servo_acts, 0] = controller.servo_stiffness
            m.actuator_biasprm[self._servo_acts, 1] = -controller.servo_stiffness
        n = len(JOINT_NAMES)
        self._targets = np.zeros(n + 1)  # column n stays 0: the pair of unpaired actuators
        self._forces = np.zeros(n)
        self._sent_forces = b""
        self._pair_of_drive = self._pair[self._drive_cols]
        self._lookups: dict = {}
        self.data = d
        mujoco.mj_forward(m, d)
        # views held once: each attribute access on MjData/MjModel builds a new array object
        self._views = (d.qpos, d.qvel, d.actuator_force, d.ctrl, m.actuator_forcerange)

    # --- indexing -------------------------------------------------------------------------

    def _index(self, m) -> None:
        mj = self._mj
        joints, actuators = name_map(m, "joint"), name_map(m, "actuator")
        n = len(JOINT_NAMES)
        self.columns = []
        self._qpos, self._dof = np.zeros(n, int), np.zeros(n, int)
        self.lower, self.upper, self.damping = np.zeros(n), np.zeros(n), np.zeros(n)
        for col, name in enumerate(JOINT_NAMES):
            j = joints.get(name, -1)
            if j < 0:
                continue
            self.columns.append(col)
            self._qpos[col], self._dof[col] = m.jnt_qposadr[j], m.jnt_dofadr[j]
            self.lower[col], self.upper[col] = m.jnt_range[j]
            self.damping[col] = m.dof_damping[m.jnt_dofadr[j]]
        # Actuator of each column: its own, or its finger's J0 tendon for J2 and J1. The
        # tendon's target is the sum of the two columns' targets (``_pair``; -1 -> 0).
        self._act = np.full(n, -1)
        self._pair = np.full(n, n)  # column n of the padded targets is always 0
        driving = []
        for col, name in enumerate(JOINT_NAMES):
            a = actuators.get(f"A_{name}", -1)
            if a >= 0 and f"A_{name}" in REQUIRED_ACTUATORS:
                self._act[col] = a
                driving.append(col)
        for f in LONG_FINGERS:
            F = f.upper()
            a = actuators[f"A_{F}J0"]
            j2, j1 = JOINT_NAMES.index(f"{F}J2"), JOINT_NAMES.index(f"{F}J1")
            self._act[j2] = self._act[j1] = a
            self._pair[j2] = j1  # the tendon's target: J2's + J1's
            driving.append(j2)
        self._distal_joints = np.array([joints[f"{f.upper()}J1"] for f in LONG_FINGERS])
        self._servo_acts = np.array([actuators[f"A_{f.upper()}{j}"] for f in LONG_FINGERS
                                     for j in ("J4", "J3", "J0")])  # fmt: skip
        self._drive_cols = np.array(driving)
        self._drive_acts = self._act[self._drive_cols]
        body_of = m.geom_bodyid
        self._object_body = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, OBJECT_BODY)
        self._is_object = body_of == self._object_body
        self._body_names = [
            shadow_name(mj.mj_id2name(m, mj.mjtObj.mjOBJ_BODY, b), "body") or ""
            for b in range(m.nbody)
        ]
        self._geom_link = [self._body_names[b] for b in body_of]
        palm = name_map(m, "body")["palm"]
        d = mj.MjData(m)
        mj.mj_kinematics(m, d)
        pos, rot = d.xpos[palm].copy(), d.xmat[palm].reshape(3, 3).copy()
        same = not pos.any() and np.array_equal(rot, np.eye(3))
        self._palm = None if same else (pos, rot, d.xquat[palm].copy())
        self._object_geoms = np.flatnonzero(self._is_object)
        self._finger_geoms = {
            f: [g for g in range(m.ngeom)
                if self._geom_link[g] in links and (m.geom_contype[g] or m.geom_conaffinity[g])]
            for f, links in FINGER_LINKS.items()
        }

    # --- the interface --------------------------------------------------------------------

    def reset_joints(self, cols: Sequence[int], values: Sequence[float]) -> None:
        cols = np.asarray(cols, int)
        self.data.qpos[self._qpos[cols]] = values
        self.data.qvel[self._dof[cols]] = 0.0
        self._mj.mj_forward(self.model, self.data)

    def penetrations(self, margin: float = 0.0) -> list[tuple[str, float]]:
        out = []
        d = self.data
        for i in range(d.ncon):
            g1, g2 = d.contact.geom1[i], d.contact.geom2[i]
            hand = g2 if self._is_object[g1] else g1
            if self._is_object[g1] != self._is_object[g2] and d.contact.dist[i] < -margin:
                out.append((self._geom_link[hand], float(d.contact.dist[i])))
        return out

    def _lookup(self, cols) -> tuple:
        """The index arrays of a set of record columns, built once per set: the controller
        passes the same few column arrays every tick (``_GraspRun.movable``, its watch list,
        the thumb), so a tick costs one dictionary look-up instead of three fancy indexings
        of index arrays and an ``asarray``. Keyed by the object's id; the entry holds the
        object itself, so its id cannot be reused while cached, and a list (which may be
        changed in place) is never cached."""
        found = self._lookups.get(id(cols))
        if found is not None and found[0] is cols:
            return found[1:]
        c = np.asarray(cols, int)
        found = (c, self._qpos[c], self._dof[c], self._act[c])
        if isinstance(cols, np.ndarray) and not cols.flags.writeable:
            self._lookups[id(cols)] = (cols, *found)
        return found

    def set_targets(self, cols: Sequence[int], targets: Sequence[float],
                    forces: Sequence[float]) -> None:  # fmt: skip
        c = self._lookup(cols)[0]
        t = self._targets
        t[c] = targets
        dc, acts = self._drive_cols, self._drive_acts
        _, _, _, ctrl, forcerange = self._views
        ctrl[acts] = t[dc] + t[self._pair_of_drive]
        self._forces[c] = forces
        f = self._forces[dc]
        sent = f.tobytes()
        if sent != self._sent_forces:  # they change a few times a grasp
            self._sent_forces = sent
            forcerange[acts, 0] = -f
            forcerange[acts, 1] = f

    def step(self) -> None:
        self._mj.mj_step(self.model, self.data, SUBSTEPS)

    def read(self, cols: Sequence[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        _, qpos, dof, act = self._lookup(cols)
        q, v, force = self._views[:3]
        # integer-array indexing copies: the caller owns the arrays
        return q[qpos], v[dof], force[act]

    def _pairs(self):
        d = self.data
        n = d.ncon
        geoms = d.contact.geom[:n]
        obj = self._is_object[geoms]
        keep = np.flatnonzero(obj[:, 0] != obj[:, 1])
        return keep, geoms, obj

    def touching(self) -> set[str]:
        keep, geoms, obj = self._pairs()
        links = self._geom_link
        return {links[geoms[i, 1] if obj[i, 0] else geoms[i, 0]] for i in keep}

    def contacts(self) -> list[Contact]:
        mj, m, d = self._mj, self.model, self.data
        keep, geoms, obj = self._pairs()
        force = np.zeros(6)
        out = []
        for i in keep:
            normal = d.contact.frame[i, :3].copy()  # from geom1 to geom2
            if not obj[i, 0]:
                normal = -normal  # the object's outward normal points at the hand
            hand = geoms[i, 1] if obj[i, 0] else geoms[i, 0]
            position = d.contact.pos[i] - 0.5 * d.contact.dist[i] * normal  # on the object
            mj.mj_contactForce(m, d, int(i), force)
            if self._palm is not None:
                palm_pos, palm_rot, _ = self._palm
                position, normal = palm_rot.T @ (position - palm_pos), palm_rot.T @ normal
            out.append((self._geom_link[hand], position, normal, float(force[0])))
        return out

    def sweep_clear_fraction(self, cols: Sequence[int], goal: np.ndarray,
                             finger: str) -> float:  # fmt: skip
        mj, m, d = self._mj, self.model, self.data
        cols = np.asarray(cols, int)
        hand_geoms = self._finger_geoms[finger]
        fromto = np.zeros(6)
        clear = 0
        for k in range(1, SWEEP_POSES + 1):
            d.qpos[self._qpos[cols]] = goal * (k / SWEEP_POSES)
            mj.mj_kinematics(m, d)
            if self._near(hand_geoms, fromto):
                break
            clear = k
        d.qpos[self._qpos[cols]] = 0.0
        mj.mj_forward(m, d)
        return clear / SWEEP_POSES

    def _near(self, hand_geoms, fromto) -> bool:
        """Whether any of ``hand_geoms`` is within SWEEP_CLEARANCE of the object (bounding
        spheres first, all pairs at once: most pairs are far apart)."""
        mj, m, d = self._mj, self.model, self.data
        hand, obj = np.asarray(hand_geoms), self._object_geoms
        gaps = np.linalg.norm(d.geom_xpos[hand][:, None] - d.geom_xpos[obj][None], axis=2)
        gaps -= m.geom_rbound[hand][:, None] + m.geom_rbound[obj][None]
        for i, j in zip(*np.nonzero(gaps <= SWEEP_CLEARANCE), strict=True):
            g, o = int(hand[i]), int(obj[j])
            if mj.mj_geomDistance(m, d, g, o, SWEEP_CLEARANCE, fromto) < SWEEP_CLEARANCE:
                return True
        return False

    def bare_step_rate(self, steps: int) -> float:
        mj, m, d = self._mj, self.model, self.data
        start = time.perf_counter()
        for _ in range(steps):
            mj.mj_step(m, d, SUBSTEPS)
        return steps / (time.perf_counter() - start)

    def snapshot(self, path: str | Path, size: int = 480) -> Path:
        import cv2

        mj = self._mj
        try:
            renderer = mj.Renderer(self.model, size, size)
            tiles = []
            for azimuth, elevation in ((0.0, -10.0), (50.0, -25.0)):
                camera = mj.MjvCamera()
                camera.lookat[:] = (0.0, -0.05, 0.1)
                camera.distance, camera.azimuth, camera.elevation = 0.36, azimuth, elevation
                renderer.update_scene(self.data, camera)
                tiles.append(renderer.render())
            renderer.close()
        except Exception as exc:  # noqa: BLE001 - no OpenGL context on this machine
            why = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise UsageError(
                f"--snapshot with the mujoco engine needs OpenGL (MUJOCO_GL=egl or osmesa): {why}"
            ) from None
        path = Path(path)
        if not cv2.imwrite(str(path), cv2.cvtColor(np.hstack(tiles), cv2.COLOR_RGB2BGR)):
            raise UsageError(f"cannot write snapshot {path}")
        return path

    def close(self) -> None:
        if self.model is not None and not self._proto.spare:
            self._proto.spare.append((self.model, self.data))  # the next grasp of this size
        self.model = self.data = self._views = None


class _Prototype(NamedTuple):
    shape: object  # held so its id is not reused while cached
    model: object
    index: dict
    spare: list
    """At most one closed engine's (model, data), reused by the next engine of this prototype:
    copying the model and allocating its data cost ~1.2 ms a grasp (3%). Every model field a
    grasp changes (the object's pose, friction, force limits) is set again on reuse, and
    ``mj_resetData`` restores the data, so a reused pair gives bit-identical records; engines
    alive at once get copies of their own."""


_PROTOTYPES: OrderedDict[tuple, _Prototype] = OrderedDict()
PROTOTYPES_KEPT = 8
"""Compiled models kept per process: a dataset grasps each size at several poses, and the pose
is only the object body's position and orientation, set on a copy (compiling a torus's 24
convex pieces takes ~40 ms, a grasp ~100 ms)."""


def clear_compiled() -> None:
    """Forget the compiled models (benchmarks time a grasp on a size never seen)."""
    _PROTOTYPES.clear()


def _prototype(shape, params, controller, hand_model) -> _Prototype:
    """The compiled hand + object (at the origin) and its indices, made once per shape, sizes,
    hand and timestep (the project's own hand's read from the disk cache where another process
    compiled it: :mod:`.mujoco_cache`)."""
    digest = controller.hand_model_digest if hand_model == controller.hand_model else None
    key = (id(shape), shape.name, tuple(sorted(params.items())), float(controller.timestep),
           float(controller.phalanx_scale), str(hand_model), digest)  # fmt: skip
    found = _PROTOTYPES.get(key)
    if found is not None and found.shape is shape:
        _PROTOTYPES.move_to_end(key)
        return found
    import mujoco

    if hand_model and controller.phalanx_scale != 1.0:
        raise UsageError("phalanx_scale changes the project's own hand, not a --hand-model")
    geoms = object_geoms(shape, params)

    def compile_model():
        spec = (load_hand_spec(hand_model, digest) if hand_model
                else mujoco.MjSpec.from_string(_hand_xml(str(mjcf_path()))))  # fmt: skip
        if controller.phalanx_scale != 1.0:
            _scale_phalanges(spec, controller.phalanx_scale)
        spec.option.timestep = controller.timestep / SUBSTEPS
        body = spec.worldbody.add_body(name=OBJECT_BODY)
        for k, geom in enumerate(geoms):
            # collides with every hand geom that collides at all, never with itself
            extra = {"contype": 0, "conaffinity": ALL_BITS, "condim": 3,
                     "rgba": [0.25, 0.55, 0.85, 1.0]}  # fmt: skip
            if geom.kind == "mesh":
                spec.add_mesh(name=f"object{k}", uservert=np.asarray(geom.vertices).ravel())
                body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"object{k}", **extra)
            else:
                kind = getattr(mujoco.mjtGeom, f"mjGEOM_{geom.kind.upper()}")
                size = [*geom.size, 0.0, 0.0][:3]
                body.add_geom(type=kind, size=size, quat=list(geom.quat), **extra)
        return spec.compile()

    if hand_model:  # its file may read others (meshes): compiled, not kept on disk
        model = compile_model()
    else:
        step = controller.timestep / SUBSTEPS
        model = compiled_model(geoms, step, float(controller.phalanx_scale), compile_model)
    holder = SimpleNamespace(_mj=mujoco)
    MujocoEngine._index(holder, model)
    proto = _Prototype(shape, model, vars(holder), [])
    _PROTOTYPES[key] = proto
    while len(_PROTOTYPES) > PROTOTYPES_KEPT:
        _PROTOTYPES.popitem(last=False)
    return proto


def _scale_phalanges(spec, scale: float) -> None:
    """Every phalanx ``scale`` times longer (as ``scene.scale_phalanges`` does to the URDF):
    the z of its geoms and of the bodies it carries, and its capsules' half lengths."""
    from ..scene import PHALANX_LINKS

    for name in PHALANX_LINKS:
        body = spec.body(name)
        if body is None:
            continue
        for geom in body.geoms:
            geom.pos = [geom.pos[0], geom.pos[1], geom.pos[2] * scale]
            geom.size = [geom.size[0], geom.size[1] * scale, geom.size[2]]
        for child in body.bodies:
            child.pos = [child.pos[0], child.pos[1], child.pos[2] * scale]
        ipos = body.ipos
        body.ipos = [ipos[0], ipos[1], ipos[2] * scale]

