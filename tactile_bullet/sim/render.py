"""Grasp pictures with PyBullet's CPU renderer (TinyRenderer: works headless, no display).

A snapshot shows the final grasp from labelled viewpoints, each framed on the hand and the
object together; a video replays the recorded joint angles of the closing hand. Replaying the
record (the object is static, so the joint angles are the whole state) keeps the grasp itself
untouched: rendering never runs inside the controller's loop, and the record stays
bit-identical with or without pictures.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..errors import UsageError

VIEWS: dict[str, tuple[float, float, float]] = {
    # label -> direction from the scene's centre to the camera, in the palm frame (x from the
    # little finger toward the first finger and thumb, z along the fingers; the object lies on
    # the -y side of the palm)
    "palm side": (0.25, -1.0, 0.35),
    "little-finger side": (-1.0, -0.5, 0.35),
}
"""The palm side shows the object's full width across the fingers (a cylinder's length, so it
does not read as a ball); the little-finger side shows how far each finger curled."""

FOV_DEG = 40.0
VIDEO_SUFFIXES = (".mp4", ".gif")
VIDEO_FPS = 30
MAX_VIDEO_FRAMES = 120
"""Frames at most in a video by default: every 2nd sample of the 60 Hz record plays in real
time at 30 frames per second, and a long grasp is sampled more sparsely, so rendering stays a
few seconds (TinyRenderer draws one 240 px view in ~15-35 ms)."""


def framing(scene) -> tuple[np.ndarray, np.ndarray]:
    """The box (lowest and highest corner, m) around the hand's links and the object: what
    every view keeps in frame (the palm and wrist are link -1)."""
    c = scene.client
    boxes = [c.getAABB(scene.hand, link) for link in range(-1, c.getNumJoints(scene.hand))]
    boxes += [c.getAABB(body) for body in scene.objects]
    return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)


def camera(box: tuple[np.ndarray, np.ndarray], direction) -> tuple[np.ndarray, np.ndarray]:
    """Eye and target that fit ``box`` into a square view from ``direction``: the target is
    the centre of the box's outline as seen from there, the eye as close as keeps each corner
    inside the field of view (a sphere around the box would leave a third of the picture
    empty)."""
    lo, hi = box
    back = np.asarray(direction, float)
    back /= np.linalg.norm(back)
    right = np.cross([0.0, 0.0, 1.0], back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])  # fmt: skip
    a, b = corners @ right, corners @ up
    target = ((a.max() + a.min()) / 2) * right + ((b.max() + b.min()) / 2) * up
    target += ((corners @ back).max() + (corners @ back).min()) / 2 * back
    rel = corners - target
    half = np.tan(np.radians(FOV_DEG) / 2.0) / 1.08  # an 8% margin
    spread = np.maximum(np.abs(rel @ right), np.abs(rel @ up))
    distance = float(np.max(rel @ back + spread / half))
    return target + distance * back, target


def render_view(
    scene, direction, size: int, box: tuple[np.ndarray, np.ndarray] | None = None
) -> np.ndarray:
    """One square RGB image (``size`` pixels) of ``box`` (default: hand and object) seen
    from ``direction``."""
    from .scene import import_pybullet

    pybullet = import_pybullet()
    eye, target = camera(box if box is not None else framing(scene), direction)
    c = scene.client
    view = c.computeViewMatrix(eye.tolist(), target.tolist(), [0.0, 0.0, 1.0])
    far = 2.0 * float(np.linalg.norm(eye - target))
    proj = c.computeProjectionMatrixFOV(FOV_DEG, 1.0, 0.01, far)
    _, _, rgba, _, _ = c.getCameraImage(
        size, size, view, proj, renderer=pybullet.ER_TINY_RENDERER,
        lightDirection=(eye - target).tolist(), shadow=0,
    )  # fmt: skip
    return np.asarray(rgba, np.uint8).reshape(size, size, 4)[:, :, :3]


def labelled_views(scene, size: int, box=None, caption: str = "") -> np.ndarray:
    """Every view side by side, each with its label in the corner (and ``caption`` after the
    first label)."""
    import cv2

    tiles = []
    for k, (label, direction) in enumerate(VIEWS.items()):
        tile = np.ascontiguousarray(render_view(scene, direction, size, box))
        text = f"{label}  {caption}" if caption and k == 0 else label
        scale = max(size / 640.0, 0.35)
        cv2.putText(tile, text, (8, int(24 * scale) + 6), cv2.FONT_HERSHEY_SIMPLEX, scale,
                    (40, 40, 40), 1 if size < 400 else 2, cv2.LINE_AA)  # fmt: skip
        tiles.append(tile)
    return np.hstack(tiles)


def snapshot(scene, path: str | Path, size: int = 480) -> Path:
    """Render the final grasp from every view, side by side, into one PNG."""
    import cv2

    image = labelled_views(scene, size)
    path = Path(path)
    if not cv2.imwrite(str(path), cv2.cvtColor(image, cv2.COLOR_RGB2BGR)):
        raise UsageError(f"cannot write snapshot {path}")
    return path


def video_frames(record, scene, every: int, size: int) -> Iterator[np.ndarray]:
    """The closing hand: the recorded joint angles of every ``every``-th sample (and the
    last) set on the scene's hand and drawn from every view, framed once on the open and the
    closed hand so the camera stays still."""
    cols = [(k, n) for k, n in enumerate(record.joint_names) if n in scene.joint_index]

    def pose(i: int) -> None:  # the welded wrist has no joint to set
        scene.reset_hand({n: float(record.angles[i, k]) for k, n in cols})

    rows = list(range(0, len(record.time), every))
    if rows[-1] != len(record.time) - 1:
        rows.append(len(record.time) - 1)
    pose(0)  # the open fingers reach further than the closed ones: frame both
    first = framing(scene)
    pose(-1)
    last = framing(scene)
    box = (np.minimum(first[0], last[0]), np.maximum(first[1], last[1]))
    for i in rows:
        pose(i)
        yield labelled_views(scene, size, box, f"t = {record.time[i]:.2f} s")


def video_step(samples: int, every: int | None = None) -> int:
    """Samples per frame: ``every`` when given, else every 2nd (real time), or more to stay
    within :data:`MAX_VIDEO_FRAMES`."""
    if every is not None:
        if every < 1:
            raise UsageError(f"--video-every must be at least 1, got {every}")
        return every
    return max(2, -(-samples // MAX_VIDEO_FRAMES))


def check_video_path(path: str | Path) -> Path:
    """Refuse, before any simulation, a video name the writers cannot make."""
    path = Path(path)
    if path.suffix.lower() not in VIDEO_SUFFIXES:
        raise UsageError(f"--video {path}: the name must end in .mp4 or .gif")
    return path


def write_video(
    record, shape, path: str | Path, size: int = 240, every: int | None = None
) -> dict:
    """Replay ``record`` (a grasp of ``shape``, a Shape) as an mp4 (OpenCV) or gif (Pillow)
    video at :data:`VIDEO_FPS`; returns ``{"path", "frames", "every", "size"}`` (``size``
    the side of one view in pixels; the frame holds every view side by side)."""
    from .scene import Scene

    path = check_video_path(path)
    if record.angles is None or len(record.time) < 2:
        raise UsageError("a video needs the grasp's time series (the record has none)")
    step = video_step(len(record.time), every)
    scene = Scene(shape, record.params, record.pose, visual=True,
                  phalanx_scale=record.controller.phalanx_scale)  # fmt: skip
    try:
        frames = list(video_frames(record, scene, step, size))
    finally:
        scene.close()
    from ..files import atomic_path

    with atomic_path(path, "video") as tmp:  # no half-written video if anything fails
        if path.suffix.lower() == ".gif":
            _write_gif(frames, tmp, VIDEO_FPS)
        else:
            _write_mp4(frames, tmp, VIDEO_FPS)
    return {"path": str(path), "frames": len(frames), "every": step, "size": size}


def _write_mp4(frames: list[np.ndarray], path: Path, fps: int) -> None:
    import cv2

    height, width = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (width, height))
    if not writer.isOpened():
        raise UsageError("cannot write an mp4 video with this OpenCV build: try a .gif name")
    try:
        for image in frames:
            writer.write(cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    finally:
        writer.release()


def _write_gif(frames: list[np.ndarray], path: Path, fps: int) -> None:
    from PIL import Image

    images = [Image.fromarray(f) for f in frames]
    images[0].save(path, save_all=True, append_images=images[1:], loop=0,
                   duration=round(1000 / fps), optimize=False)  # fmt: skip
