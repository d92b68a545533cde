"""One PyBullet world: the Shadow hand fixed at the wrist and a static object in front of it.

Every Scene owns its own client (DIRECT unless asked for the GUI), so scenes can run in parallel
processes and a fresh scene per grasp keeps records bit-identical. The palm frame of the kinematics
sheet is the world frame: the forearm base is placed so that, at zero wrist angles, the palm link
sits at the origin.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import re
import sys
import tempfile
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..hand import FINGER_LINKS, JOINT_NAMES, urdf_path
from ..objects.placement import object_position
from ..objects.shapes import Shape
from ..records import Pose


def _is_surface(piece) -> bool:
    """Whether a shape's piece is an exact triangle surface (a trimesh or a cached
    ``Surface``: it has faces) rather than the points of a convex hull."""
    return hasattr(piece, "faces")


FOREARM_TO_PALM = np.array([0.0, -0.010, 0.247])
"""Palm origin in the forearm frame at zero wrist angles (sheet: WRJ2 then WRJ1 origins)."""

FRICTION = 0.8
"""Default lateral friction of hand links and object (``ControllerSettings.friction``)."""

PHALANX_LINKS = tuple(
    f"{finger}{part}"
    for finger in ("ff", "mf", "rf", "lf", "th")
    for part in ("proximal", "middle", "distal")
)
"""Links whose length ``phalanx_scale`` changes (with the joints they carry)."""

FIXED_JOINTS = ("WRJ2", "WRJ1")
"""Joints welded for grasping: the arm holds the palm still (the thesis' hand was mounted and
its wrist took no part). Welded in the URDF the simulator loads, so the palm joins the fixed
base: a motor on the wrist made the solver oscillate once two fingers pressed, and a lock by
zero-width limits yielded 7 deg under a large torus. Records report them at 0 rad."""

CONTACT_DAMPING_RATIO = 0.01
"""Contact damping (N s/m) per unit of ``contact_stiffness`` (N/m) on a soft contact: a 10 ms
time constant, which keeps a fingertip pressed at thresT from bouncing at 240 Hz."""

SOLVER_ITERATIONS = 50
"""Bullet's default (the contact solver is tuned for it at 240 Hz)."""

ARMATURE_INERTIA = 1e-5
"""Floor (kg m^2) on every hand link's principal inertias. The sheet's bare-link values go
down to 2.6e-7 (knuckles); a real joint also carries its actuator's and tendon's reflected
inertia, and without it Bullet's multibody solver diverges as soon as two or more fingers press
on the object at once (measured: J3 swinging +-0.5 rad, contact forces of kN). With the floor
four fingers settle on a cylinder with forces of ~20 N and no oscillation."""


@contextlib.contextmanager
def quiet_stdout(streams: tuple[str, ...] = ("stdout",)) -> Iterator[None]:
    """Silence C-level writes to the given standard streams: PyBullet prints its build time on
    stderr when imported and every merged link on stdout while loading, and ``--json`` output
    must stay one clean document (a person's terminal, one clean line)."""
    saved: list[tuple[int, int]] = []
    try:
        for name in streams:
            stream = getattr(sys, name)
            try:
                fd = stream.fileno()
            except (AttributeError, OSError, ValueError):  # pytest capture, notebooks
                continue
            stream.flush()
            saved.append((fd, os.dup(fd)))
        with open(os.devnull, "wb") as null:
            for fd, _ in saved:
                os.dup2(null.fileno(), fd)
            try:
                yield
            finally:
                _flush_c_stdout()  # C's buffered printf output goes to /dev/null, not later
    finally:
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)


def _flush_c_stdout() -> None:
    import ctypes

    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):
        pass


def import_pybullet():
    """pybullet, imported without its build-time banner (which its C module prints at import
    on stdout): every import of pybullet in the package goes through here."""
    if "pybullet" in sys.modules and "pybullet_utils.bullet_client" in sys.modules:
        return sys.modules["pybullet"]
    with quiet_stdout(("stdout", "stderr")):
        import pybullet
        import pybullet_utils.bullet_client  # noqa: F401

    return pybullet


def grasping_urdf(phalanx_scale: float = 1.0) -> Path:
    """The hand's URDF with FIXED_JOINTS welded (and its phalanges scaled by
    ``phalanx_scale``), cached next to the system's temp files (written once per content,
    atomically, so parallel workers can share it)."""
    path = _welded_urdf(urdf_path(), float(phalanx_scale))
    if not path.exists():  # a temp cleaner removed it during a long run: write it again
        _welded_urdf.cache_clear()
        path = _welded_urdf(urdf_path(), float(phalanx_scale))
    return path


def scale_phalanges(text: str, scale: float) -> str:
    """URDF text with every phalanx ``scale`` times longer: the z of the origins inside the
    phalanx links, their capsules' lengths, and the origins of the joints they carry (the next
    phalanx, the tip frame). Radii, knuckles, palm and masses stay: another hand of the same
    model, whose fingers a manufacturing or calibration tolerance made a little longer."""

    def scaled(match: re.Match, group: int) -> str:
        value = float(match.group(group)) * scale
        return match.group(0).replace(match.group(group), f"{value:.6g}", 1)

    z_origin = re.compile(r'xyz="0 0 ([-0-9.e]+)"')
    length = re.compile(r'length="([-0-9.e]+)"')
    for link in PHALANX_LINKS:
        block = re.compile(rf'<link name="{link}">.*?</link>', re.S)
        body = block.search(text)
        if body is None:
            raise RuntimeError(f"hand URDF lacks link {link}")
        new = z_origin.sub(lambda m: scaled(m, 1), body.group(0))
        new = length.sub(lambda m: scaled(m, 1), new)
        text = text[: body.start()] + new + text[body.end() :]
        carried = re.compile(
            rf'<joint name="[^"]+" type="\w+">\s*<parent link="{link}"/>.*?</joint>', re.S
        )
        text = carried.sub(lambda m: z_origin.sub(lambda z: scaled(z, 1), m.group(0)), text)
    return text


@functools.lru_cache(maxsize=4)
def _welded_urdf(source: Path, phalanx_scale: float = 1.0) -> Path:
    """Read, weld and hash once per process and source, not once per grasp."""
    text = source.read_text()
    for name in FIXED_JOINTS:
        text = text.replace(
            f'<joint name="{name}" type="revolute">', f'<joint name="{name}" type="fixed">'
        )
    if phalanx_scale != 1.0:
        text = scale_phalanges(text, phalanx_scale)
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    path = Path(tempfile.gettempdir()) / f"tactile-bullet-hand-{digest}.urdf"
    if not path.exists():
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)
    return path


@dataclass(frozen=True)
class Placement:
    """Where the object's frame ends up in the palm frame."""

    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]


def place_object(shape: Shape, params: Mapping[str, float], pose: Pose) -> Placement:
    """The object's position (:func:`~tactile_bullet.objects.placement.object_position`) and
    its rotation about the palm normal as PyBullet's quaternion (PyBullet's own conversion,
    so records stay bit-identical to those made before the placement moved)."""
    p = import_pybullet()
    quat = p.getQuaternionFromEuler([0.0, pose.rotation, 0.0])
    position = object_position(shape, params, pose)
    return Placement(position, tuple(float(v) for v in quat))


class Scene:
    """The hand and one static object in a private PyBullet client."""

    def __init__(
        self,
        shape: Shape,
        params: Mapping[str, float],
        pose: Pose,
        *,
        timestep: float = 1.0 / 240.0,
        gui: bool = False,
        visual: bool = False,
        friction: float = FRICTION,
        phalanx_scale: float = 1.0,
        contact_stiffness: float = 0.0,
    ) -> None:
        self.friction, self.phalanx_scale = float(friction), float(phalanx_scale)
        self.contact_stiffness = float(contact_stiffness)
        p = import_pybullet()
        from pybullet_utils import bullet_client

        with quiet_stdout():
            self._connect(p, bullet_client, gui)
        c = self.client
        c.setTimeStep(timestep)
        c.setGravity(0, 0, -9.81)
        c.setPhysicsEngineParameter(numSolverIterations=SOLVER_ITERATIONS)
        with quiet_stdout():
            self.hand = self._load_hand(p)
        self._index_links(p)
        self.shape, self.params, self.pose = shape, dict(params), pose
        self.placement = place_object(shape, params, pose)
        self.objects = self._add_object(visual)

    def _connect(self, p, bullet_client, gui: bool) -> None:
        if not gui:
            self.client = bullet_client.BulletClient(connection_mode=p.DIRECT)
            return
        no_window = UsageError("--gui needs a display (PyBullet could not open a window)")
        if not os.environ.get("DISPLAY") and sys.platform.startswith("linux"):
            raise no_window
        try:
            self.client = bullet_client.BulletClient(connection_mode=p.GUI)
        except Exception as exc:  # noqa: BLE001 - a bare pybullet.error without a display
            raise no_window from exc
        if not self.client.isConnected():
            raise no_window

    def _load_hand(self, p) -> int:
        return self.client.loadURDF(
            str(grasping_urdf(self.phalanx_scale)),
            basePosition=(-FOREARM_TO_PALM).tolist(),
            useFixedBase=True,
            # Merging the fixed tip frames into the distal links matters: a 0.1 g tip link
            # on a fixed joint makes the multibody solver blow up on the first contact.
            flags=p.URDF_USE_INERTIA_FROM_FILE | p.URDF_MERGE_FIXED_LINKS,
        )

    def _index_links(self, p) -> None:
        c = self.client
        self.joint_index: dict[str, int] = {}
        self.link_index: dict[str, int] = {}
        self.link_name: dict[int, str] = {-1: "palm"}  # forearm, wrist and palm merged
        for j in range(c.getNumJoints(self.hand)):
            info = c.getJointInfo(self.hand, j)
            link = info[12].decode()
            self.link_index[link] = j
            self.link_name[j] = link
            if info[2] == p.JOINT_REVOLUTE:
                self.joint_index[info[1].decode()] = j
                c.enableJointForceTorqueSensor(self.hand, j, True)
            inertia = c.getDynamicsInfo(self.hand, j)[2]
            c.changeDynamics(
                self.hand,
                j,
                lateralFriction=self.friction,
                localInertiaDiagonal=[max(v, ARMATURE_INERTIA) for v in inertia],
            )
        missing = [n for n in JOINT_NAMES if n not in self.joint_index and n not in FIXED_JOINTS]
        if missing:
            raise RuntimeError(f"URDF {urdf_path()} lacks joints {missing}")
        self.joints = [self.joint_index[n] for n in JOINT_NAMES if n not in FIXED_JOINTS]
        self.columns = [JOINT_NAMES.index(n) for n in JOINT_NAMES if n not in FIXED_JOINTS]
        self.lower = np.zeros(len(JOINT_NAMES))
        self.upper = np.zeros(len(JOINT_NAMES))
        for col, j in zip(self.columns, self.joints, strict=True):
            self.lower[col], self.upper[col] = c.getJointInfo(self.hand, j)[8:10]
        self.finger_link_ids = {
            f: [self.link_index[n] for n in links if n in self.link_index]
            for f, links in FINGER_LINKS.items()
        }

    # --- object ---------------------------------------------------------------------------

    def _add_object(self, visual: bool) -> list[int]:
        c = self.client
        p = import_pybullet()
        bodies = []
        for piece in self.shape.pieces(**self.params):
            if _is_surface(piece):  # exact concave surface (static only)
                col = c.createCollisionShape(
                    p.GEOM_MESH,
                    vertices=np.asarray(piece.vertices).tolist(),
                    indices=np.asarray(piece.faces).ravel().tolist(),
                )
            else:  # convex hull of the vertices
                col = c.createCollisionShape(p.GEOM_MESH, vertices=np.asarray(piece).tolist())
            body = c.createMultiBody(
                baseMass=0.0,
                baseCollisionShapeIndex=col,
                basePosition=self.placement.position,
                baseOrientation=self.placement.orientation,
            )
            c.changeDynamics(body, -1, lateralFriction=self.friction)
            if self.contact_stiffness > 0:
                c.changeDynamics(
                    body, -1, contactStiffness=self.contact_stiffness,
                    contactDamping=CONTACT_DAMPING_RATIO * self.contact_stiffness,
                )  # fmt: skip
            bodies.append(body)
        if visual:
            mesh = self.shape.mesh(**self.params)
            vis = c.createVisualShape(
                p.GEOM_MESH,
                vertices=np.asarray(mesh.vertices).tolist(),
                indices=np.asarray(mesh.faces).ravel().tolist(),
                rgbaColor=[0.25, 0.55, 0.85, 1.0],
            )
            c.createMultiBody(
                baseMass=0.0,
                baseCollisionShapeIndex=-1,
                baseVisualShapeIndex=vis,
                basePosition=self.placement.position,
                baseOrientation=self.placement.orientation,
            )
        return bodies

    # --- hand state -----------------------------------------------------------------------

    def reset_hand(self, angles: Mapping[str, float] | None = None) -> None:
        """Teleport joints (no dynamics): the open hand (all zero) unless told otherwise."""
        pose = dict.fromkeys(self.joint_index, 0.0)
        pose.update(angles or {})
        for name, value in pose.items():
            self.client.resetJointState(self.hand, self.joint_index[name], value, 0.0)

    def penetrations(self, margin: float = 0.0) -> list[tuple[str, float]]:
        """Hand links that overlap the object deeper than ``margin`` (m), with their depth."""
        c = self.client
        c.performCollisionDetection()
        out = []
        for body in self.objects:
            for pt in c.getContactPoints(bodyA=self.hand, bodyB=body):
                if pt[8] < -margin:
                    out.append((self.link_name[pt[3]], float(pt[8])))
        return out

    def contacts(self) -> list[tuple[str, np.ndarray, np.ndarray, float]]:
        """Current hand-object contacts in the palm frame: (link, position on the object,
        object's outward normal, normal force)."""
        c = self.client
        pos, orn = c.getBasePositionAndOrientation(self.hand)
        rot = np.array(c.getMatrixFromQuaternion(orn)).reshape(3, 3)
        origin = np.asarray(pos) + rot @ FOREARM_TO_PALM  # the palm frame, welded to the base
        out = []
        for body in self.objects:
            for pt in c.getContactPoints(bodyA=self.hand, bodyB=body):
                world_pos = np.asarray(pt[6])
                normal = np.asarray(pt[7])  # on B (object) toward A (hand): outward normal
                out.append(
                    (
                        self.link_name[pt[3]],
                        rot.T @ (world_pos - origin),
                        rot.T @ normal,
                        float(pt[9]),
                    )
                )
        return out

    def touching_links(self) -> set[int]:
        """Link indices of the hand currently touching the object (cheap: no frames)."""
        c = self.client
        links: set[int] = set()
        for body in self.objects:
            for pt in c.getContactPoints(bodyA=self.hand, bodyB=body):
                links.add(pt[3])
        return links

    def close(self) -> None:
        try:
            self.client.disconnect()
        except Exception:  # noqa: BLE001 - already gone
            pass

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
