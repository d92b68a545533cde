"""The ``bullet`` engine: PyBullet, through today's :class:`~tactile_bullet.sim.scene.Scene`.

Every call maps one to one onto the PyBullet calls the controller made before the engine
interface existed (same order, same float arithmetic), so records stay byte-identical to those
made before it (``tests/test_engine_digests.py``).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ...errors import UsageError
from ...hand import FINGER_LINKS, JOINT_NAMES
from ...objects.shapes import Shape
from ...records import ControllerSettings, Pose
from ..scene import Scene
from .base import Contact, Engine

SWEEP_CLEARANCE = 0.005
"""Gap (m) a finger's links keep from the object over the part of its sweep that is skipped
(the thumb's always, the fingers' with ``ControllerSettings.preshape``): the last 5 mm are
closed under control."""
SWEEP_POSES = 48
"""Poses checked along a sweep: at most ~3.5 mm of fingertip travel between two of them,
under the clearance, so no contact can be missed between two checked poses."""


class BulletEngine(Engine):
    """Algorithm 1's view of a PyBullet :class:`Scene` (one private client)."""

    name = "bullet"

    def __init__(
        self,
        shape: Shape,
        params: Mapping[str, float],
        pose: Pose,
        controller: ControllerSettings,
        *,
        gui: bool = False,
        visual: bool = False,
    ) -> None:
        from ..scene import import_pybullet

        p = import_pybullet()  # the one import of pybullet: its build-time banner silenced
        if controller.hand_model is not None:
            raise UsageError("--hand-model is an MJCF model: use it with --engine mujoco")
        self.scene = scene = Scene(
            shape, params, pose, timestep=controller.timestep, gui=gui, visual=visual,
            friction=controller.friction, phalanx_scale=controller.phalanx_scale,
            contact_stiffness=controller.contact_stiffness,
        )  # fmt: skip
        self.client, self.hand = scene.client, scene.hand
        self._position_control = p.POSITION_CONTROL
        n = len(JOINT_NAMES)
        self.columns = list(scene.columns)
        self._ids = np.full(n, -1)
        self._ids[self.columns] = scene.joints
        self.lower, self.upper = scene.lower, scene.upper
        self.damping = np.zeros(n)
        self.damping[self.columns] = [
            self.client.getJointInfo(self.hand, j)[6] for j in scene.joints
        ]
        self._finger_links = {
            f: [scene.link_index[nm] for nm in links if nm in scene.link_index]
            for f, links in FINGER_LINKS.items()
        }

    def _joint_ids(self, cols: Sequence[int]) -> list[int]:
        return self._ids[np.asarray(cols)].tolist()

    def reset_joints(self, cols: Sequence[int], values: Sequence[float]) -> None:
        for j, value in zip(self._joint_ids(cols), values, strict=True):
            self.client.resetJointState(self.hand, j, float(value), 0.0)

    def penetrations(self, margin: float = 0.0) -> list[tuple[str, float]]:
        return self.scene.penetrations(margin)

    def set_targets(self, cols: Sequence[int], targets: Sequence[float],
                    forces: Sequence[float]) -> None:  # fmt: skip
        self.client.setJointMotorControlArray(
            self.hand, self._joint_ids(cols), self._position_control,
            targetPositions=np.asarray(targets, float).tolist(),
            forces=np.asarray(forces, float).tolist(),
        )  # fmt: skip

    def step(self) -> None:
        self.client.stepSimulation()

    def read(self, cols: Sequence[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        states = self.client.getJointStates(self.hand, self._joint_ids(cols))
        return (
            np.array([s[0] for s in states]),
            np.array([s[1] for s in states]),
            np.array([s[3] for s in states]),
        )

    def touching(self) -> set[str]:
        names = self.scene.link_name
        return {names[i] for i in self.scene.touching_links()}

    def contacts(self) -> list[Contact]:
        return self.scene.contacts()

    def sweep_clear_fraction(self, cols: Sequence[int], goal: np.ndarray,
                             finger: str) -> float:  # fmt: skip
        c, hand = self.client, self.hand
        joint_ids, links = self._joint_ids(cols), self._finger_links[finger]
        clear = 0
        for k in range(1, SWEEP_POSES + 1):
            for j, angle in zip(joint_ids, goal * (k / SWEEP_POSES), strict=True):
                c.resetJointState(hand, j, float(angle), 0.0)
            if any(
                c.getClosestPoints(hand, body, SWEEP_CLEARANCE, linkIndexA=link)
                for body in self.scene.objects
                for link in links
            ):
                break
            clear = k
        for j in joint_ids:
            c.resetJointState(hand, j, 0.0, 0.0)
        return clear / SWEEP_POSES

    def bare_step_rate(self, steps: int) -> float:
        client = self.client
        start = time.perf_counter()
        for _ in range(steps):
            client.stepSimulation()
        return steps / (time.perf_counter() - start)

    def snapshot(self, path: str | Path, size: int = 480) -> Path:
        from ..render import snapshot

        return snapshot(self.scene, path, size)

    def close(self) -> None:
        self.scene.close()
