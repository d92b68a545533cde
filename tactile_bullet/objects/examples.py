"""The example object set: household-like solids as mesh files, made here with trimesh.

``tactile-bullet make-objects --out DIR [--only bottle,ball,box]`` writes them (package code,
so it works in any folder, no repository needed).

Ten solids of revolution (bottle, can, ball, bowl, egg, mug body, pear, vase, cup, spool) and
four that are not (box, banana, hexagonal prism, soap bar), each in its own file in mixed
formats and units, as found in the wild: STL in millimetres, glTF/GLB in metres with y up,
OBJ, PLY and OFF in metres or centimetres, standing upright (their main axis along the file's
z or y). Beside them, ``train.toml`` and ``test.toml``: object-set sweeps for instance
recognition (labels = object names) whose test poses are held out: random offsets and
rotations between the training grid's values.

Sizes are those of small household objects that fit the Shadow hand (sections 12-60 mm in
radius, 6-16 cm long). Nothing is downloaded; the same command writes the same files.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import trimesh

from ..errors import UsageError
from ..files import atomic_path, existing_outputs

SECTIONS = 64


def revolve(z, r, sections: int = SECTIONS) -> trimesh.Trimesh:
    """Solid of revolution about z from a closed profile (r = 0 at both ends)."""
    mesh = trimesh.creation.revolve(np.column_stack([r, z]), sections=sections)
    mesh.fix_normals()
    return mesh


def smooth_profile(z_knots, r_knots, n: int = 80):
    """A profile through the knots (monotone cubic), closed on the axis at both ends."""
    from scipy.interpolate import PchipInterpolator

    z = np.linspace(z_knots[0], z_knots[-1], n)
    r = np.clip(PchipInterpolator(z_knots, r_knots)(z), 0.0, None)
    r[0] = r[-1] = 0.0
    return z, r


def tube(centre: np.ndarray, radius: np.ndarray, normal: np.ndarray, sections: int = 48):
    """A closed tube along a planar centre line (k, 3) with radii (k,), 0 at both ends (the
    ends close on single vertices): watertight by construction."""
    k = len(centre)
    tangent = np.gradient(centre, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    side = np.cross(tangent, normal)
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    angles = np.linspace(0, 2 * np.pi, sections, endpoint=False)
    rings = centre[1:-1, None, :] + radius[1:-1, None, None] * (
        np.cos(angles)[None, :, None] * side[1:-1, None, :] + np.sin(angles)[None, :, None] * normal
    )
    vertices = np.vstack([centre[:1], rings.reshape(-1, 3), centre[-1:]])
    faces = []
    n_rings = k - 2
    for j in range(sections):  # fan at the start
        faces.append([0, 1 + (j + 1) % sections, 1 + j])
    for i in range(n_rings - 1):
        a, b = 1 + i * sections, 1 + (i + 1) * sections
        for j in range(sections):
            j2 = (j + 1) % sections
            faces += [[a + j, a + j2, b + j], [a + j2, b + j2, b + j]]
    last, end = 1 + (n_rings - 1) * sections, len(vertices) - 1
    for j in range(sections):
        faces.append([last + j, last + (j + 1) % sections, end])
    mesh = trimesh.Trimesh(vertices, np.array(faces), process=True)
    mesh.fix_normals()
    return mesh


# --- the objects (metres, main axis along z) -----------------------------------------------


def bottle():
    z = [-0.065, -0.064, -0.02, 0.015, 0.035, 0.045, 0.064, 0.065]
    r = [0.0, 0.030, 0.031, 0.030, 0.017, 0.013, 0.013, 0.0]
    return revolve(*smooth_profile(z, r))


def can():
    z = np.array([-0.0575, -0.0575, -0.054, 0.054, 0.0575, 0.0575])
    r = np.array([0.0, 0.029, 0.033, 0.033, 0.029, 0.0])
    return revolve(z, r)


def ball():
    return trimesh.creation.icosphere(subdivisions=4, radius=0.036)


def bowl():
    """A hemispherical shell: outer 60 mm, wall 5 mm, flat rim (concave inside)."""
    t_out = np.linspace(0, np.pi / 2, 40)
    outer = np.column_stack([0.060 * np.sin(t_out), -0.060 * np.cos(t_out) + 0.03])
    inner = np.column_stack([0.055 * np.sin(t_out[::-1]), -0.055 * np.cos(t_out[::-1]) + 0.03])
    line = np.vstack([outer, inner])
    mesh = trimesh.creation.revolve(line[:, :2], sections=SECTIONS)
    mesh.fix_normals()
    return mesh


def egg():
    z = np.linspace(-0.03, 0.03, 60)
    u = z / 0.03
    r = 0.022 * np.sqrt(np.clip(1 - u**2, 0, None)) * (1 - 0.2 * u)
    r[0] = r[-1] = 0.0
    return revolve(z, r)


def mug_body():
    """A tapered cup, open at the top, 4 mm wall."""
    z = np.array([-0.048, -0.048, 0.048, 0.048, -0.044, -0.044])
    r = np.array([0.0, 0.036, 0.040, 0.036, 0.032, 0.0])
    line = np.column_stack([r, z])
    mesh = trimesh.creation.revolve(line, sections=SECTIONS)
    mesh.fix_normals()
    return mesh


def pear():
    z = [-0.055, -0.05, -0.03, -0.01, 0.015, 0.035, 0.05, 0.055]
    r = [0.0, 0.022, 0.036, 0.037, 0.026, 0.020, 0.014, 0.0]
    return revolve(*smooth_profile(z, r))


def vase():
    """A waisted vase: a one-sheet hyperboloid, 24 mm waist, 42 mm ends, flat ends."""
    z = np.linspace(-0.06, 0.06, 61)
    r = 0.024 * np.sqrt(1 + 0.52 * (z / 0.03) ** 2)
    return revolve(np.concatenate([[-0.06], z, [0.06]]), np.concatenate([[0.0], r, [0.0]]))


def cup():
    """A truncated cone: a paper cup, wide end 45 mm, narrow end 28 mm."""
    z = np.array([-0.06, -0.06, 0.06, 0.06])
    r = np.array([0.0, 0.045, 0.028, 0.0])
    return revolve(z, r)


def spool():
    """A cotton reel: 40 mm flanges, 24 mm core (concave)."""
    z = np.array([-0.045, -0.045, -0.035, -0.033, 0.033, 0.035, 0.045, 0.045])
    r = np.array([0.0, 0.040, 0.040, 0.024, 0.024, 0.040, 0.040, 0.0])
    return revolve(z, r)


def box():
    return trimesh.creation.box(extents=(0.055, 0.075, 0.13))


def banana():
    """A bent capsule: an arc of 130 mm radius over 75 deg, 19 mm thick, tapered ends."""
    t = np.linspace(-1, 1, 70)
    angle = np.radians(37.5) * t
    centre = np.column_stack([0.13 * np.sin(angle), np.zeros_like(t), 0.13 * (1 - np.cos(angle))])
    radius = 0.019 * np.sqrt(np.clip(1 - t**8, 0, None))
    mesh = tube(centre, radius, normal=np.array([0.0, 1.0, 0.0]))
    # stand it along z like the others
    mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    return mesh


def hex_prism():
    """A hexagonal prism (a pencil pot): circumradius 45 mm, 100 mm long."""
    return trimesh.creation.cylinder(radius=0.045, height=0.10, sections=6)


def soap():
    """A rounded bar: the convex hull of spheres at the corners of a 75 x 45 x 20 mm box."""
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    corners *= [0.010, 0.0225, 0.0375]
    ball_points = trimesh.creation.icosphere(subdivisions=2, radius=0.010).vertices
    points = (corners[:, None, :] + ball_points[None, :, :]).reshape(-1, 3)
    return trimesh.convex.convex_hull(points)


OBJECTS: dict[str, tuple[Callable[[], trimesh.Trimesh], str, str, str]] = {
    # name: (builder, file extension, unit written, up axis in the file)
    "bottle": (bottle, "stl", "mm", "z"),
    "can": (can, "obj", "m", "z"),
    "ball": (ball, "ply", "m", "z"),
    "bowl": (bowl, "glb", "m", "y"),
    "egg": (egg, "off", "cm", "z"),
    "mug_body": (mug_body, "stl", "mm", "z"),
    "pear": (pear, "obj", "m", "z"),
    "vase": (vase, "ply", "m", "z"),
    "cup": (cup, "glb", "m", "y"),
    "spool": (spool, "off", "cm", "z"),
    "box": (box, "stl", "mm", "z"),
    "banana": (banana, "obj", "m", "z"),
    "hex_prism": (hex_prism, "ply", "m", "z"),
    "soap": (soap, "glb", "m", "y"),
}
"""The example set; ``--only`` picks some."""

SCALE = {"m": 1.0, "cm": 100.0, "mm": 1000.0}
Z_TO_Y = trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0])
"""glTF is y-up: an upright object's axis goes from z to y."""

TRAIN_POSES = {
    "offset_x": [-0.01, 0.0, 0.01],
    "offset_z": [-0.01, 0.0, 0.01],
    "rotation_deg": [0, 10],
}
TEST_POSES = {
    "offset_x": {"min": -0.01, "max": 0.01},
    "offset_z": {"min": -0.01, "max": 0.01},
    "rotation_deg": {"min": 0, "max": 10},
}
TEST_SAMPLES = 6


def write_object(name: str, out: Path) -> Path:
    build, ext, unit, up = OBJECTS[name]
    mesh = build()
    if up == "y":
        mesh.apply_transform(Z_TO_Y)
    mesh.apply_scale(SCALE[unit])
    path = out / f"{name}.{ext}"
    with atomic_path(path, "example object") as tmp:
        mesh.export(tmp, file_type=ext)
    return path


def _toml_value(value) -> str:
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {v}" for k, v in value.items()) + " }"
    return "[" + ", ".join(str(v) for v in value) + "]"


def sweep_toml(names, poses: dict, mode: str, title: str, samples: int | None = None) -> str:
    lines = [f'name = "{title}"', f'mode = "{mode}"']
    if samples is not None:
        lines.append(f"samples = {samples}")
    for name in names:
        _, ext, unit, _ = OBJECTS[name]
        lines += ["", "[[objects]]", f'file = "{name}.{ext}"', f'unit = "{unit}"']
        lines += [f"{key} = {_toml_value(value)}" for key, value in poses.items()]
    return "\n".join(lines) + "\n"


def check_names(names: Sequence[str] | None) -> list[str]:
    """The object names asked for (all by default); UsageError on an unknown one."""
    names = list(OBJECTS) if names is None else list(names)
    unknown = [n for n in names if n not in OBJECTS]
    if unknown or not names:
        raise UsageError(
            f"unknown example object {unknown[0] if unknown else ''!r} "
            f"(objects: {', '.join(OBJECTS)})"
        )
    return names


def write_set(out: Path, names: Sequence[str] | None = None, force: bool = False) -> list[Path]:
    """Write the objects named (all by default) and the train/test sweeps into ``out``; an
    existing file is refused before anything is written unless ``force``."""
    names = check_names(names)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out} exists and is not a folder")
    targets = [out / f"{n}.{OBJECTS[n][1]}" for n in names] + [
        out / "train.toml",
        out / "test.toml",
    ]
    existing = [p for p in targets if p.exists() or p.is_symlink()]
    if existing and not force:
        raise UsageError(f"{existing[0]} exists (pass --force to overwrite)")
    # every target checked before the first is written: a link, a FIFO, or (with --force) a
    # file this project did not write there is refused by name, and nothing is written
    existing_outputs(out, [p.name for p in targets], "--out", force)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"cannot create {out}: {exc.strerror or exc}") from None
    paths = [write_object(n, out) for n in names]
    sweeps = {
        "train.toml": sweep_toml(names, TRAIN_POSES, "grid", "objects-train"),
        "test.toml": sweep_toml(names, TEST_POSES, "random", "objects-test", TEST_SAMPLES),
    }
    for file, text in sweeps.items():
        with atomic_path(out / file, "sweep") as tmp:
            tmp.write_text(text)
    return paths + [out / "train.toml", out / "test.toml"]
