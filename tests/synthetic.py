"""Synthetic grasp records from the wrapping theory, so descriptor and classifier tests run
without the simulator.

Joint angles are the theory's (``patterns.theoretical_angles``, the hand model: each long
finger wraps the cross-section of radius r(x) at its own place on O-O', theta = s / r shared
phalanx by phalanx from the hand's own knuckles; a finger beside the object closes to 90 deg).
Its tip touches the surface at the angle it has wrapped, where the object's outward normal is
(-r'(x), cos phi, sin phi) normalised (phi in the palm's y-z plane from +y, the palm side). The
thumb touches the object from below. Sizes are drawn across each shape's valid range, the object
is offset along O-O', and Gaussian noise is added to angles and normals.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from tactile_bullet.hand import FINGER_X, JOINT_NAMES, LONG_FINGERS, THUMB_OPPOSED
from tactile_bullet.objects.shapes import BUILTIN_SHAPES, THESIS_SHAPES
from tactile_bullet.records import ControllerSettings, GraspRecord, Pose, save_record

START_PHI = 0.2
"""Where the finger first meets the object, from the palm side (rad)."""

SHAPES = {s.name: s for s in BUILTIN_SHAPES}


def random_params(shape: str, rng: np.random.Generator) -> dict[str, float]:
    """Sizes drawn uniformly in the shape's valid ranges (redrawn until consistent)."""
    spec = SHAPES[shape]
    for _ in range(100):
        params = {k: float(rng.uniform(p.min, p.max)) for k, p in spec.params.items()}
        try:
            return spec.resolve(params)
        except ValueError:
            continue
    return spec.resolve()


def _normal(slope: float, phi: float, rng, noise: float) -> np.ndarray:
    n = np.array([-slope, np.cos(phi), np.sin(phi)]) + rng.normal(0.0, noise, 3)
    return n / np.linalg.norm(n)


def make_record(
    shape: str,
    params: Mapping[str, float] | None = None,
    rng: np.random.Generator | None = None,
    noise: float = 0.02,
    offset_x: float = 0.0,
    samples: int = 12,
) -> GraspRecord:
    """One synthetic record of ``shape`` (default sizes unless ``params``)."""
    from tactile_bullet.perception.patterns import theoretical_angles

    rng = np.random.default_rng(0) if rng is None else rng
    spec = SHAPES[shape]
    values = spec.resolve(params)
    pose = Pose((offset_x, 0.0, 0.0))
    wrapped = theoretical_angles(spec, values, pose=pose)
    final = np.zeros(len(JOINT_NAMES))
    index = {n: i for i, n in enumerate(JOINT_NAMES)}
    links, normals, positions, forces, touching = [], [], [], [], []
    for column, finger in enumerate(LONG_FINGERS):
        x = FINGER_X[finger] - offset_x
        r = float(spec.radius(np.array([x]), **values)[0])
        slope = float(
            (
                spec.radius(np.array([x + 1e-4]), **values)[0]
                - spec.radius(np.array([x - 1e-4]), **values)[0]
            )
            / 2e-4
        )
        theta = wrapped[:, column] + rng.normal(0.0, noise, 3)
        name = finger.upper()
        for joint, angle in zip(("J3", "J2", "J1"), theta, strict=True):
            final[index[f"{name}{joint}"]] = angle
        final[index[f"{name}J4"]] = rng.normal(0.0, noise)
        if r > 0:
            phi = START_PHI + float(theta.sum())
            links.append(f"{finger}distal")
            normals.append(_normal(slope, phi, rng, noise))
            positions.append([x, r * np.cos(phi), r * np.sin(phi)])
            forces.append(float(rng.uniform(0.5, 2.0)))
            touching.append(finger)
    final[index["LFJ5"]] = rng.normal(0.0, noise)
    for joint, angle in THUMB_OPPOSED.items():
        final[index[joint]] = angle + rng.normal(0.0, noise)
    r0 = float(spec.radius(np.array([-offset_x]), **values)[0])
    if r0 > 0:
        phi = -np.pi / 2 - 0.3
        links.append("thdistal")
        normals.append(_normal(0.0, phi, rng, noise))
        positions.append([0.0, r0 * np.cos(phi), r0 * np.sin(phi)])
        forces.append(float(rng.uniform(0.5, 2.0)))
        touching.append("th")
    ramp = np.linspace(0.0, 1.0, samples)[:, None]
    angles = ramp * final[None, :]
    return GraspRecord(
        shape=shape,
        params=values,
        pose=pose,
        controller=ControllerSettings(),
        seed=0,
        time=np.linspace(0.0, 1.0, samples),
        angles=angles,
        efforts=np.zeros_like(angles),
        final_angles=final,
        contact_link=np.asarray(links, dtype="U16"),
        contact_position=np.asarray(positions, dtype=float).reshape(-1, 3),
        contact_normal=np.asarray(normals, dtype=float).reshape(-1, 3),
        contact_force=np.asarray(forces, dtype=float),
        fingers_in_contact=tuple(touching),
        steps=240,
    )


def make_records(
    shapes: Sequence[str] = THESIS_SHAPES,
    per_shape: int = 10,
    seed: int = 0,
    noise: float = 0.02,
    max_offset: float = 0.008,
) -> list[GraspRecord]:
    """``per_shape`` records of each shape: random sizes, offsets along O-O', noise."""
    rng = np.random.default_rng(seed)
    out = []
    for shape in shapes:
        for _ in range(per_shape):
            out.append(
                make_record(
                    shape,
                    random_params(shape, rng),
                    rng,
                    noise=noise,
                    offset_x=float(rng.uniform(-max_offset, max_offset)),
                )
            )
    return out


SMALL_SWEEP = """
name = "small"
[[shapes]]
name = "cylinder"
params = { radius = [0.03, 0.04] }
[[shapes]]
name = "sphere"
params = { radius = [0.04, 0.05] }
"""
"""Four real grasps (two cylinders, two spheres): the dataset tests' sweep."""


def write_records(folder, records):
    """``records`` as a folder of record files, the way tests hand the CLI a small dataset."""
    folder.mkdir(parents=True, exist_ok=True)
    for i, rec in enumerate(records):
        save_record(rec, folder / f"rec{i:03d}.npz")
    return folder
