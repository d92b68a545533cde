"""Grasp snapshots with PyBullet's CPU renderer (TinyRenderer: works headless, no display)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UsageError

VIEWS = {
    # (camera target in the palm frame, distance, yaw, pitch) in metres and degrees
    "side": ((0.0, -0.05, 0.1), 0.34, 90.0, -10.0),
    "oblique": ((0.0, -0.04, 0.1), 0.36, 140.0, -25.0),
}


def snapshot(scene, path: str | Path, width: int = 640, height: int = 480) -> Path:
    """Render the scene from two viewpoints side by side into one PNG."""
    import cv2

    from .scene import import_pybullet

    pybullet = import_pybullet()
    p = scene.client
    tiles = []
    for target, dist, yaw, pitch in VIEWS.values():
        view = p.computeViewMatrixFromYawPitchRoll(target, dist, yaw, pitch, 0.0, 2)
        proj = p.computeProjectionMatrixFOV(45.0, width / height, 0.01, 2.0)
        _, _, rgba, _, _ = p.getCameraImage(
            width, height, view, proj, renderer=pybullet.ER_TINY_RENDERER,
            lightDirection=[0.5, -1.0, 1.0], shadow=0,
        )  # fmt: skip
        tiles.append(np.asarray(rgba, np.uint8).reshape(height, width, 4)[:, :, :3])
    image = np.hstack(tiles)
    path = Path(path)
    if not cv2.imwrite(str(path), cv2.cvtColor(image, cv2.COLOR_RGB2BGR)):
        raise UsageError(f"cannot write snapshot {path}")
    return path
