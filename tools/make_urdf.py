"""Write ``urdf/shadow_hand.urdf``: the project's own Shadow Dexterous Hand E (right hand).

Every number below is taken from ``docs/hand.md`` (joint origins,
axes, limits, efforts, damping, masses, COMs, inertias and collision primitives), except where a
comment says it is this project's choice (the sheet is silent there).

Run from the repository root::

    python tools/make_urdf.py            # writes urdf/shadow_hand.urdf
    python tools/make_urdf.py OUT.urdf   # writes elsewhere

Collision and visual shapes are primitives only (boxes, cylinders and capsules). ``<capsule>``
is a PyBullet extension of URDF (``radius``, ``length`` = the cylinder part, axis along z).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO / "urdf" / "shadow_hand.urdf"

# --------------------------------------------------------------------------------------------
# Joints: (name, parent, child, origin xyz, origin rpy, axis, lower deg, upper deg)
# --------------------------------------------------------------------------------------------
Z3 = (0.0, 0.0, 0.0)

KNUCKLES = {  # palm -> <f>knuckle origin, J4 axis (the sheet's "Joints" table)
    "ff": ((0.033, 0.0, 0.095), (0.0, -1.0, 0.0)),
    "mf": ((0.011, 0.0, 0.099), (0.0, -1.0, 0.0)),
    "rf": ((-0.011, 0.0, 0.095), (0.0, 1.0, 0.0)),
    # LF: palm -> lfmetacarpal (LFJ5) -> lfknuckle (LFJ4); see LF_METACARPAL below.
    "lf": ((0.0, 0.0, 0.06579), (0.0, 1.0, 0.0)),
}
PROXIMAL_LEN, MIDDLE_LEN, DISTAL_TO_TIP = 0.045, 0.025, 0.026
J3_LIMITS_DEG = (-15.0, 90.0)  # the sheet's main value (some models use 0 .. 90)

WRIST_JOINTS = [
    ("WRJ2", "forearm", "wrist", (0.0, -0.010, 0.213), Z3, (0.0, 1.0, 0.0), -30.0, 10.0),
    ("WRJ1", "wrist", "palm", (0.0, 0.0, 0.034), Z3, (1.0, 0.0, 0.0), -40.0, 28.0),
]

LF_METACARPAL = (
    "LFJ5", "palm", "lfmetacarpal", (-0.033, 0.0, 0.02071), Z3,
    (0.573576, 0.0, 0.819152), 0.0, 45.0,
)  # fmt: skip

THUMB_JOINTS = [
    ("THJ5", "palm", "thbase", (0.034, -0.00858, 0.029), (0.0, math.pi / 4, 0.0),
     (0.0, 0.0, -1.0), -60.0, 60.0),
    ("THJ4", "thbase", "thproximal", Z3, Z3, (1.0, 0.0, 0.0), 0.0, 70.0),
    ("THJ3", "thproximal", "thhub", (0.0, 0.0, 0.038), Z3, (1.0, 0.0, 0.0), -12.0, 12.0),
    ("THJ2", "thhub", "thmiddle", Z3, Z3, (0.0, -1.0, 0.0), -40.0, 40.0),
    ("THJ1", "thmiddle", "thdistal", (0.0, 0.0, 0.032), (0.0, 0.0, -math.pi / 2),
     (1.0, 0.0, 0.0), -15.0, 90.0),
]  # fmt: skip
THUMB_DISTAL_TO_TIP = 0.0275


def finger_joints(f: str) -> list[tuple]:
    """J4 .. J1 of one long finger (LF's J5 is added separately)."""
    F = f.upper()
    knuckle_xyz, j4_axis = KNUCKLES[f]
    parent = "lfmetacarpal" if f == "lf" else "palm"
    x_axis = (1.0, 0.0, 0.0)
    return [
        (f"{F}J4", parent, f"{f}knuckle", knuckle_xyz, Z3, j4_axis, -20.0, 20.0),
        (f"{F}J3", f"{f}knuckle", f"{f}proximal", Z3, Z3, x_axis, *J3_LIMITS_DEG),
        (f"{F}J2", f"{f}proximal", f"{f}middle", (0.0, 0.0, PROXIMAL_LEN), Z3, x_axis, 0.0, 90.0),
        (f"{F}J1", f"{f}middle", f"{f}distal", (0.0, 0.0, MIDDLE_LEN), Z3, x_axis, 0.0, 90.0),
    ]


def all_revolute_joints() -> list[tuple]:
    joints = list(WRIST_JOINTS)
    for f in ("ff", "mf", "rf"):
        joints += finger_joints(f)
    joints += [LF_METACARPAL] + finger_joints("lf")
    joints += THUMB_JOINTS
    return joints


# Fixed joints to the tip frames: (name, parent, child, xyz)
TIP_JOINTS = [
    (f"{f.upper()}tip", f"{f}distal", f"{f}tip", (0.0, 0.0, DISTAL_TO_TIP))
    for f in ("ff", "mf", "rf", "lf")
] + [("THtip", "thdistal", "thtip", (0.0, 0.0, THUMB_DISTAL_TO_TIP))]

# Effort (N m), velocity (rad/s), damping: the sheet's "Efforts, damping, gains" table.
THUMB_DRIVE = {
    "THJ5": (5.0, 4.0, 0.2),
    "THJ4": (3.0, 4.0, 0.2),
    "THJ3": (2.0, 4.0, 0.2),
    "THJ2": (2.0, 2.0, 0.1),
    "THJ1": (1.0, 4.0, 0.2),
}


def drive(joint: str) -> tuple[float, float, float]:
    if joint == "WRJ2":
        return (10.0, 2.0, 0.1)
    if joint == "WRJ1":
        return (30.0, 2.0, 0.1)
    if joint in THUMB_DRIVE:
        return THUMB_DRIVE[joint]
    return (2.0, 2.0, 0.1)  # finger J1..J4 and LFJ5


# --------------------------------------------------------------------------------------------
# Links: mass (kg), COM z (m), inertia diagonal, collision shapes, colour
# A shape is (kind, size, xyz, rpy): box size = full extents; cylinder/capsule size =
# (radius, length of the cylinder part). Capsule and cylinder axes are along the shape's z.
# --------------------------------------------------------------------------------------------
R_X = (0.0, math.pi / 2, 0.0)  # turns a shape's z axis onto the link's x axis

INERTIAL = {  # the sheet's mass table; the distal rows include the tip
    "palm": (0.300, 0.035, (3.581e-4, 5.287e-4, 1.91e-4)),
    "knuckle": (0.008, 0.0, (2.6e-7, 2.6e-7, 3.2e-7)),
    "proximal": (0.030, 0.0225, (9.8e-6, 1.0e-5, 1.8e-6)),
    "middle": (0.017, 0.0125, (2.6e-6, 2.7e-6, 8.7e-7)),
    "distal": (0.013, 0.0131, (1.121e-6, 1.281e-6, 5.3e-7)),
    "lfmetacarpal": (0.030, 0.04, (1.45e-5, 1.638e-5, 4.272e-6)),
    "thbase": (0.010, 0.0, (1.6e-7, 1.6e-7, 1.6e-7)),
    "thproximal": (0.040, 0.019, (1.36e-5, 1.36e-5, 3.13e-6)),
    "thhub": (0.005, 0.0, (1e-6, 1e-6, 3e-7)),
    "thmiddle": (0.020, 0.016, (5.1e-6, 5.1e-6, 1.21e-6)),
    "thdistal": (0.017, 0.0146, (2.278e-6, 2.378e-6, 1e-6)),
    # Not in the sheet (project's placeholders): the forearm is the fixed base, so its mass
    # does not act; the wrist's is a small plausible value.
    "forearm": (1.8, 0.09, (0.01, 0.01, 0.001)),
    "wrist": (0.1, 0.0, (6.4e-5, 4.4e-5, 5.3e-5)),
    # Tip frames: negligible mass (PyBullet wants mass > 0 on non-base links).
    "tip": (1e-4, 0.0, (1e-9, 1e-9, 1e-9)),
}

COLLISION = {  # the sheet's "Collision primitives" section, converted to metres
    "palm": [
        ("box", (0.064, 0.0222, 0.098), (0.011, 0.0, 0.038), Z3),
        ("box", (0.022, 0.0222, 0.050), (-0.032, 0.0, 0.014), Z3),
    ],
    "knuckle": [("cylinder", (0.009, 0.018), Z3, R_X)],
    "proximal": [("capsule", (0.009, 0.040), (0.0, 0.0, 0.025), Z3)],
    "middle": [("capsule", (0.009, 0.025), (0.0, 0.0, 0.0125), Z3)],
    # r 8 mm, cylinder 0 .. 24 mm: the pad ends 32 mm past J1.
    "distal": [("capsule", (0.008, 0.024), (0.0, 0.0, 0.012), Z3)],
    # The sheet gives r 10.5-13 and 9-11 mm for the thumb; cylinder parts span the segment.
    "thproximal": [("capsule", (0.012, 0.038), (0.0, 0.0, 0.019), Z3)],
    "thmiddle": [("capsule", (0.010, 0.032), (0.0, 0.0, 0.016), Z3)],
    # Project's choice (not in the sheet): r 9 mm, pad ends 33 mm past THJ1 (tip at 27.5).
    "thdistal": [("capsule", (0.009, 0.024), (0.0, 0.0, 0.012), Z3)],
    # Project's choice: fills the palm's little-finger corner above the lower palm box.
    "lfmetacarpal": [("box", (0.022, 0.0222, 0.050), (0.0, 0.0, 0.040), Z3)],
    # Project's choice: a short cylinder across the WRJ1 axis.
    "wrist": [("cylinder", (0.0135, 0.030), Z3, R_X)],
    # thbase, thhub, tips: no collision; forearm: visual only (it is the fixed base).
}
FOREARM_VISUAL = [("cylinder", (0.03, 0.18), (0.0, -0.010, 0.09), Z3)]

COLOURS = {
    "grey": (0.55, 0.55, 0.58, 1.0),
    "dark": (0.22, 0.22, 0.24, 1.0),
    "skin": (0.87, 0.72, 0.60, 1.0),
}


def link_kind(link: str) -> str:
    """The sheet's row for a link name: 'ffproximal' -> 'proximal', 'thtip' -> 'tip'."""
    for suffix in ("knuckle", "proximal", "middle", "distal", "tip"):
        if link.startswith(("ff", "mf", "rf", "lf")) and link.endswith(suffix):
            return suffix
    return "tip" if link == "thtip" else link


def colour_of(kind: str) -> str:
    if kind in ("distal", "thdistal"):
        return "skin"
    if kind in ("knuckle", "thbase", "thhub", "wrist", "forearm"):
        return "dark"
    return "grey"


# --------------------------------------------------------------------------------------------
# XML writing
# --------------------------------------------------------------------------------------------
def num(v: float) -> str:
    s = f"{v:.10g}"
    return "0" if s == "-0" else s


def vec(v) -> str:
    return " ".join(num(x) for x in v)


def geometry_xml(kind: str, size) -> str:
    if kind == "box":
        return f'<box size="{vec(size)}"/>'
    radius, length = size
    return f'<{kind} radius="{num(radius)}" length="{num(length)}"/>'


def link_xml(link: str) -> str:
    kind = link_kind(link)
    mass, com_z, (ixx, iyy, izz) = INERTIAL[kind]
    lines = [
        f'  <link name="{link}">',
        "    <inertial>",
        f'      <origin xyz="0 0 {num(com_z)}" rpy="0 0 0"/>',
        f'      <mass value="{num(mass)}"/>',
        f'      <inertia ixx="{num(ixx)}" ixy="0" ixz="0" iyy="{num(iyy)}" iyz="0"'
        f' izz="{num(izz)}"/>',
        "    </inertial>",
    ]
    colour = colour_of(kind)
    shapes = COLLISION.get(kind, [])
    visuals = FOREARM_VISUAL if kind == "forearm" else shapes
    for shape_kind, size, xyz, rpy in visuals:
        lines += [
            "    <visual>",
            f'      <origin xyz="{vec(xyz)}" rpy="{vec(rpy)}"/>',
            f"      <geometry>{geometry_xml(shape_kind, size)}</geometry>",
            f'      <material name="{colour}"/>',
            "    </visual>",
        ]
    for shape_kind, size, xyz, rpy in shapes:
        lines += [
            "    <collision>",
            f'      <origin xyz="{vec(xyz)}" rpy="{vec(rpy)}"/>',
            f"      <geometry>{geometry_xml(shape_kind, size)}</geometry>",
            "    </collision>",
        ]
    lines.append("  </link>")
    return "\n".join(lines)


def revolute_xml(name, parent, child, xyz, rpy, axis, lo_deg, hi_deg) -> str:
    effort, velocity, damping = drive(name)
    return "\n".join([
        f'  <joint name="{name}" type="revolute">',
        f'    <parent link="{parent}"/>',
        f'    <child link="{child}"/>',
        f'    <origin xyz="{vec(xyz)}" rpy="{vec(rpy)}"/>',
        f'    <axis xyz="{vec(axis)}"/>',
        f'    <limit lower="{num(math.radians(lo_deg))}" upper="{num(math.radians(hi_deg))}"'
        f' effort="{num(effort)}" velocity="{num(velocity)}"/>',
        f'    <dynamics damping="{num(damping)}" friction="0"/>',
        "  </joint>",
    ])  # fmt: skip


def fixed_xml(name, parent, child, xyz) -> str:
    return "\n".join([
        f'  <joint name="{name}" type="fixed">',
        f'    <parent link="{parent}"/>',
        f'    <child link="{child}"/>',
        f'    <origin xyz="{vec(xyz)}" rpy="0 0 0"/>',
        "  </joint>",
    ])  # fmt: skip


HEADER = """<?xml version="1.0"?>
<!--
  Shadow Dexterous Hand E, right hand: tactile-bullet's own model.
  GENERATED by tools/make_urdf.py from docs/hand.md; do not edit
  by hand, edit the script and re-run it.

  Frames. Root link: forearm. The palm frame is the `palm` link frame: origin on the WRJ1
  axis, +z toward the fingertips, +x toward the first finger and thumb, -y the palm (grip) side.
  At zero wrist angles the palm origin is at (0, -0.010, 0.247) in the forearm frame.
  Positive flexion (J3, J2, J1) moves the fingertips toward -y.
  Tip frames (fftip ... thtip) at zero pose, palm frame: FF (0.033, 0, 0.191),
  MF (0.011, 0, 0.195), RF (-0.011, 0, 0.191), LF (-0.033, 0, 0.1825),
  TH (0.103, -0.0086, 0.098).

  J1/J2 tendon coupling. On the real hand one motor drives J0 = J1 + J2 (J2 leading, J1
  following). It is NOT modelled here: PyBullet ignores URDF transmissions. J1 and J2 are
  independent revolute joints in this file; the coupling is realised by the project's
  controller.

  Geometry: primitives only. <capsule radius length> (length = cylinder part, axis z) is a
  PyBullet extension of URDF; everything else is standard URDF.
-->
<robot name="shadow_hand_e_right">"""


def build() -> str:
    revolute = all_revolute_joints()
    links = ["forearm"] + [j[2] for j in revolute]
    links += [t[2] for t in TIP_JOINTS]
    parts = [HEADER]
    for name, rgba in COLOURS.items():
        parts.append(f'  <material name="{name}"><color rgba="{vec(rgba)}"/></material>')
    parts += [link_xml(link) for link in links]
    parts += [revolute_xml(*j) for j in revolute]
    parts += [fixed_xml(*t) for t in TIP_JOINTS]
    parts.append("</robot>\n")
    return "\n".join(parts)


def write_model(kind: str, text_of, default_out: Path, argv: list[str] | None = None) -> int:
    """The command line both generators share: write ``text_of()`` to OUT (default
    ``default_out``); ``kind`` names the file format in the help."""
    parser = argparse.ArgumentParser(description=f"Write the Shadow hand {kind} from docs/hand.md.")
    parser.add_argument("out", nargs="?", type=Path, default=default_out,
                        help=f"where to write it (default: {default_out.relative_to(REPO)})")
    out = parser.parse_args(argv).out
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text_of())
    print(f"wrote {out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    return write_model("URDF", build, DEFAULT_OUT, argv)


if __name__ == "__main__":
    raise SystemExit(main())
