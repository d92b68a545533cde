"""The enclosure grasp: the thesis' Algorithm 1 on the simulated Shadow hand.

Per finger (ff, mf, rf, lf), independently and all at once:

1. stage J3: raise the proximal joint's target by ``delta`` each control tick until the effort on
   J3 or any joint downstream (J2, J1) exceeds ``thres_t`` (torque mode) or a phalanx at or
   downstream of the proximal one touches the object (contact mode), or J3 reaches its limit;
2. stage J0: raise the coupled J0 = J1 + J2 the same way until the distal joint J1 reports the
   effort (or the distal phalanx the contact), or J0 reaches pi.

The J1/J2 tendon is modelled in the controller (PyBullet ignores URDF transmissions): J0's
increments go to J2 first, as on the real hand where the middle phalanx leads; once J2 is
blocked (its effort over the threshold, or its limit) the tendon's further travel goes to J1.
A joint that stops holds the angle it was measured at (position control, J3 at the sheet's
2 N m, the J0 tendon at 1 N m). Before the fingers move, the thumb is brought to opposition,
stopping where it meets the object, and held there. The grasp ends when every finger is done
(or at ``max_time``, flagged ``did_not_settle``); the hand then holds its targets
``settle_steps`` steps and the final state is read.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping

import numpy as np

from .errors import UsageError
from .hand import (
    FINGER_LINKS,
    FINGERS,
    JOINT_NAMES,
    LONG_FINGERS,
    THUMB_OPPOSED,
)
from .records import ControllerSettings, GraspRecord, Pose
from .scene import Scene
from .shapes import Shape

J3, J0 = 0, 1
DONE = 2
THUMB_SPEED_RATIO = 1.6
"""The thumb's joints are specified at 4 rad/s against 2 for the fingers': it closes faster."""
EFFORT_FILTER_S = 0.01
"""Time constant (s) of the first-order filter on the efforts Algorithm 1 compares."""
PENETRATION_TOLERANCE = 0.002
"""An object overlapping the open hand deeper than this (m) is refused as a pose."""


def resolve_shape(name: str) -> Shape:
    """The Shape called ``name`` from the plugin registry (built-ins included); an unknown
    name is a UsageError listing the known ones."""
    from .plugins import get_shape

    return get_shape(name)


class _Finger:
    """Algorithm 1's state for one long finger."""

    __slots__ = ("name", "j3", "j2", "j1", "stage", "t3", "t2", "t1", "j2_free", "links")

    def __init__(self, name: str, scene: Scene) -> None:
        up = name.upper()
        self.name = name
        self.j3, self.j2, self.j1 = (JOINT_NAMES.index(f"{up}J{k}") for k in (3, 2, 1))
        self.stage = J3
        self.t3 = self.t2 = self.t1 = 0.0
        self.j2_free = True
        ids = scene.link_index
        self.links = (
            ids[f"{name}proximal"],
            ids[f"{name}middle"],
            {ids[f"{name}distal"]},
        )


def simulate_grasp(
    shape: str | Shape,
    params: Mapping[str, float] | None = None,
    pose: Pose | None = None,
    controller: ControllerSettings | None = None,
    seed: int = 0,
    *,
    gui: bool = False,
    scene_hook=None,
) -> GraspRecord:
    """Run one enclosure grasp and return its record.

    ``shape`` is a registered name (or a Shape); ``params`` its sizes in metres (defaults filled
    in and range-checked); ``pose`` the object's offset and rotation; ``seed`` is stored in the
    record (the grasp itself is deterministic: the same inputs give a bit-identical record).
    ``scene_hook(scene)`` is called after the grasp, before the client closes (snapshots).
    """
    spec = shape if isinstance(shape, Shape) else resolve_shape(shape)
    values = spec.resolve(params)
    pose = pose or Pose()
    ctl = controller or ControllerSettings()
    scene = Scene(spec, values, pose, timestep=ctl.timestep, gui=gui, visual=scene_hook is not None)
    try:
        record = _run(scene, spec, values, pose, ctl, int(seed), scene_hook)
    finally:
        scene.close()
    identity = getattr(spec, "identity", None)  # a mesh file's (meshes.MeshShape)
    return dataclasses.replace(record, mesh=identity) if identity else record


def _run(scene, spec, values, pose, ctl, seed, scene_hook) -> GraspRecord:
    import pybullet as p

    c, hand = scene.client, scene.hand
    scene.reset_hand()
    overlap = scene.penetrations(PENETRATION_TOLERANCE)
    if overlap:
        link, depth = min(overlap, key=lambda t: t[1])
        raise UsageError(
            f"pose puts the {spec.name} inside the open hand ({link} overlaps it by "
            f"{-depth * 1000:.1f} mm): move it away from the palm (--offset y < 0) or shrink it"
        )

    # Arrays below are indexed by record column (JOINT_NAMES order); `movable` are the columns
    # of joints the simulator has (the wrist is welded, see scene.FIXED_JOINTS) and `ids[col]`
    # PyBullet's index of a column's joint.
    n = len(JOINT_NAMES)
    joints, movable = scene.joints, scene.columns
    ids = np.full(n, -1)
    ids[movable] = joints
    targets = np.zeros(n)
    forces = np.full(n, ctl.motor_force)
    # The proximal joint gets the sheet's 2 N m: it must hold while the coupled J0 (the sheet's
    # tendon at 1 N m) presses the middle and distal phalanges into the object, whose reaction
    # acts on J3 through a longer lever. At 1 N m the proximal was pushed back 0.4 rad.
    forces[[JOINT_NAMES.index(f"{f.upper()}J3") for f in LONG_FINGERS]] = 2.0 * ctl.motor_force
    damping = np.zeros(n)
    damping[movable] = [c.getJointInfo(hand, j)[6] for j in joints]
    fingers = [_Finger(f, scene) for f in LONG_FINGERS]
    upper = scene.upper
    setmotors = c.setJointMotorControlArray
    getstates = c.getJointStates
    torque_mode = ctl.mode == "torque"
    thres, delta = ctl.thres_t, ctl.delta

    sample_every = max(1, round(1.0 / (ctl.sample_rate * ctl.timestep)))
    max_steps = int(math.ceil(ctl.max_time / ctl.timestep))
    times, angle_rows, effort_rows = [], [], []
    flags: list[str] = []
    step = 0

    def sample():
        states = getstates(hand, joints)
        angles, efforts = np.zeros(n), np.zeros(n)
        angles[movable] = [s[0] for s in states]
        efforts[movable] = [s[3] for s in states]
        angle_rows.append(angles)
        effort_rows.append(efforts)
        times.append(step * ctl.timestep)

    filtered = np.zeros(n)
    smooth = ctl.timestep / (EFFORT_FILTER_S + ctl.timestep)

    def external(states, idx):
        """Low-passed |motor torque - the joint's own viscous damping|: the torque the joint
        spends on something other than moving itself, i.e. on the object, as a real hand's
        compensated torque sensing reports it. Without the damping term a joint closing at
        2.4 rad/s reads 0.24 N m; without the filter the jolt of a contact on one phalanx
        trips the joints downstream of it."""
        raw = np.array([abs(s[3] - damping[i] * s[1]) for s, i in zip(states, idx, strict=True)])
        filtered[idx] += smooth * (raw - filtered[idx])
        return filtered[idx].tolist()

    setmotors(hand, joints, p.POSITION_CONTROL, targetPositions=targets[movable].tolist(),
              forces=forces[movable].tolist())  # fmt: skip
    sample()

    # Phase 1: thumb to opposition, stopping on the object if it meets it first.
    thumb = [JOINT_NAMES.index(nm) for nm in THUMB_OPPOSED]
    thumb_ids = ids[thumb].tolist()
    goal = np.array(list(THUMB_OPPOSED.values()))
    forces[thumb] = (5.0, 3.0, 2.0, 2.0, 1.0)
    n_thumb = int(math.ceil(np.abs(goal).max() / (THUMB_SPEED_RATIO * delta)))
    # The object is static, so the free part of the thumb's sweep is skipped: it starts from
    # the last pose of its path that keeps SWEEP_CLEARANCE from the object (the long fingers'
    # final angles are unchanged by this, to 0.005 deg). With `preshape` each finger's J3
    # starts the same way.
    links = scene.finger_link_ids
    first = int(math.floor(sweep_clear_fraction(scene, thumb_ids, goal, links["th"]) * n_thumb))
    targets[thumb] = goal * (first / n_thumb)
    moved = list(thumb)
    if ctl.preshape:
        for f in fingers:
            j3 = int(ids[f.j3])
            top = np.array([upper[f.j3]])
            f.t3 = targets[f.j3] = sweep_clear_fraction(scene, [j3], top, links[f.name]) * top[0]
            moved.append(f.j3)
    if first or ctl.preshape:
        for col in moved:
            c.resetJointState(hand, int(ids[col]), float(targets[col]), 0.0)
        setmotors(hand, joints, p.POSITION_CONTROL, targetPositions=targets[movable].tolist(),
                  forces=forces[movable].tolist())  # fmt: skip
        angle_rows.clear()
        effort_rows.clear()
        times.clear()
        sample()
    thumb_link_ids = set(links["th"])
    for k in range(first + 1, n_thumb + 1):
        states = getstates(hand, thumb_ids)
        if torque_mode:
            stop = max(external(states, thumb)) > thres
        else:
            stop = bool(thumb_link_ids & scene.touching_links())
        if stop:
            targets[thumb] = [s[0] for s in states]
        else:
            targets[thumb] = goal * (k / n_thumb)
        setmotors(hand, thumb_ids, p.POSITION_CONTROL, targetPositions=targets[thumb].tolist(),
                  forces=forces[thumb].tolist())  # fmt: skip
        c.stepSimulation()
        step += 1
        if step % sample_every == 0:
            sample()
        if stop:
            break

    # Phase 2: Algorithm 1 on the four fingers at once.
    watch = [j for f in fingers for j in (f.j3, f.j2, f.j1)]
    watch_ids = ids[watch].tolist()
    while True:
        if step % ctl.control_every == 0:
            states = getstates(hand, watch_ids)
            eff = external(states, watch)
            links = None if torque_mode else scene.touching_links()
            active = False
            for k, f in enumerate(fingers):
                if f.stage == DONE:
                    continue
                active = True
                e3, e2, e1 = eff[3 * k], eff[3 * k + 1], eff[3 * k + 2]
                if f.stage == J3:
                    if torque_mode:
                        hit = e3 > thres or e2 > thres or e1 > thres
                    else:
                        hit = (f.links[0] in links or f.links[1] in links
                               or bool(f.links[2] & links))  # fmt: skip
                    if hit or f.t3 >= upper[f.j3]:
                        f.stage = J0
                        f.t3 = targets[f.j3] = states[3 * k][0]
                    else:
                        f.t3 = min(f.t3 + delta, upper[f.j3])
                        targets[f.j3] = f.t3
                    continue
                # stage J0: tendon travel to J2 while it is free, then to J1
                if torque_mode:
                    j2_blocked, j1_blocked = e2 > thres, e1 > thres
                else:
                    j2_blocked, j1_blocked = f.links[1] in links, bool(f.links[2] & links)
                if f.j2_free and (j2_blocked or f.t2 >= upper[f.j2]):
                    f.j2_free = False
                    f.t2 = targets[f.j2] = states[3 * k + 1][0]
                if j1_blocked or (not f.j2_free and f.t1 >= upper[f.j1]):
                    f.stage = DONE
                    f.t1 = targets[f.j1] = states[3 * k + 2][0]
                    continue
                if f.j2_free:
                    f.t2 = min(f.t2 + delta, upper[f.j2])
                    targets[f.j2] = f.t2
                else:
                    f.t1 = min(f.t1 + delta, upper[f.j1])
                    targets[f.j1] = f.t1
            if not active:
                break
            setmotors(hand, watch_ids, p.POSITION_CONTROL,
                      targetPositions=targets[watch].tolist(),
                      forces=forces[watch].tolist())  # fmt: skip
        if step >= max_steps:
            flags.append("did_not_settle")
            break
        c.stepSimulation()
        step += 1
        if step % sample_every == 0:
            sample()

    for _ in range(ctl.settle_steps):
        c.stepSimulation()
        step += 1
        if step % sample_every == 0:
            sample()
    if times[-1] != step * ctl.timestep:
        sample()

    final = np.zeros(n)
    final[movable] = [s[0] for s in getstates(hand, joints)]
    if np.any(final < scene.lower - 0.05) or np.any(final > upper + 0.05):
        flags.append("unstable")
    contacts = scene.contacts()
    if scene_hook is not None:
        scene_hook(scene)
    link_names = np.array([ct[0] for ct in contacts], dtype="U16")
    in_contact = tuple(f for f in FINGERS if any(name in FINGER_LINKS[f] for name in link_names))
    if not any(f in in_contact for f in LONG_FINGERS):
        flags.append("no_contact")
    else:
        missing = [f for f in LONG_FINGERS if f not in in_contact]
        if missing:
            flags.append("finger_without_contact")
    return GraspRecord(
        shape=spec.name,
        params=values,
        pose=pose,
        controller=ctl,
        seed=seed,
        time=np.asarray(times, float),
        angles=np.asarray(angle_rows, float),
        efforts=np.asarray(effort_rows, float),
        final_angles=final,
        contact_link=link_names,
        contact_position=np.array([ct[1] for ct in contacts], float).reshape(-1, 3),
        contact_normal=np.array([ct[2] for ct in contacts], float).reshape(-1, 3),
        contact_force=np.array([ct[3] for ct in contacts], float),
        fingers_in_contact=in_contact,
        flags=tuple(flags),
        steps=step,
    )


SWEEP_CLEARANCE = 0.005
"""Gap (m) a finger's links keep from the object over the part of its sweep that
``ControllerSettings.preshape`` skips: it still closes the last 5 mm under control."""
SWEEP_POSES = 48
"""Poses checked along a sweep: at most ~3.5 mm of fingertip travel between two of them,
under the clearance, so no contact can be missed between two checked poses."""


def sweep_clear_fraction(
    scene: Scene, joint_ids: list[int], goal: np.ndarray, links: list[int]
) -> float:
    """The fraction of the straight joint-space sweep from 0 to ``goal`` of ``joint_ids`` over
    which ``links`` keep ``SWEEP_CLEARANCE`` from the object: 1.0 when the whole sweep is free.
    Collision queries only, no dynamics; the joints are left at 0."""
    c, hand = scene.client, scene.hand
    clear = 0
    for k in range(1, SWEEP_POSES + 1):
        for j, angle in zip(joint_ids, goal * (k / SWEEP_POSES), strict=True):
            c.resetJointState(hand, j, float(angle), 0.0)
        if any(
            c.getClosestPoints(hand, body, SWEEP_CLEARANCE, linkIndexA=link)
            for body in scene.objects
            for link in links
        ):
            break
        clear = k
    for j in joint_ids:
        c.resetJointState(hand, j, 0.0, 0.0)
    return clear / SWEEP_POSES


def timed_grasp(*args, **kwargs) -> tuple[GraspRecord, float]:
    """simulate_grasp plus its wall time (s), kept out of the record so records stay
    bit-identical between runs."""
    start = time.perf_counter()
    record = simulate_grasp(*args, **kwargs)
    return record, time.perf_counter() - start
