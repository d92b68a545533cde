"""Write ``urdf/shadow_hand.xml``: the project's Shadow hand as MuJoCo MJCF, beside the URDF.

Every number comes from ``tools/make_urdf.py``'s tables (themselves from ``docs/hand.md``): the
same joints, limits, damping, masses, inertias and collision primitives. What MJCF adds, as on
the real hand: J1 and J2 of each long finger are coupled by a fixed tendon J0 = J1 + J2 driven
by ONE position actuator (``A_FFJ0`` ...), so how the tendon's pull splits between the two
joints is the physics', not the controller's. The other joints get one position actuator each
(``A_FFJ3`` ...). Effort limits are the sheet's (J3, J4, LFJ5 2 N m; the J0 tendon 1 N m; the
thumb 5/3/2/2/1 N m); the controller sets them again per grasp.

The wrist is welded (the palm body is the world frame, as the bullet engine's palm frame):
the thesis' hand was mounted and its wrist took no part. Hand links do not collide with each
other (Bullet's default for a URDF), only with the object.

Run from the repository root::

    python tools/make_mjcf.py            # writes urdf/shadow_hand.xml
    python tools/make_mjcf.py OUT.xml    # writes elsewhere
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import make_urdf as sheet  # noqa: E402 - the URDF's tables, one source for both files

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO / "urdf" / "shadow_hand.xml"

# Project's choices (the sheet is silent on a simulator's servo): stiff position servos whose
# effort limit, not their gain, bounds the force, as PyBullet's position motors.
KP = 20.0
"""Position gain (N m/rad) of every actuator: 0.1 rad of error reaches the 2 N m limit."""
KV = 0.05
"""Velocity gain (N m s/rad), integrated implicitly: near critical damping for a finger."""
ARMATURE = 1e-5
"""Reflected actuator inertia (kg m^2) on every joint: the bullet engine's inertia floor
(sim/scene.py ARMATURE_INERTIA), the same physical idea (a real joint carries its motor's)."""
LIMIT_SOLREF = (0.005, 1.0)
"""Joint limits' (time constant s, damping ratio): stiffer than MuJoCo's default 0.02 s, under
which the tendon's 1 N m pushed J1 12 deg past its 90-deg stop (MuJoCo wants >= 2 steps);
with the limit's impedance raised to 0.99-0.999 (solimplimit) it stays within ~1 deg."""
TENDON_EFFORT = 1.0
"""The J0 tendon's effort (N m, docs/hand.md: 'the J0 tendon 1 N m')."""
LONG = ("ff", "mf", "rf", "lf")


def num(v: float) -> str:
    return sheet.num(v)


def vec(v) -> str:
    return sheet.vec(v)


def quat_of_rpy(rpy) -> tuple[float, float, float, float]:
    """URDF roll-pitch-yaw (fixed axes X, Y, Z) as MuJoCo's (w, x, y, z) quaternion."""
    r, p, y = (a / 2 for a in rpy)
    cr, sr, cp, sp = math.cos(r), math.sin(r), math.cos(p), math.sin(p)
    cy, sy = math.cos(y), math.sin(y)
    return (
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )


def geom_xml(kind: str, size, xyz, rpy, indent: str, extra: str = "") -> str:
    if kind == "box":
        mj_size = [s / 2 for s in size]
    else:  # cylinder, capsule: (radius, length of the cylinder part) -> (radius, half length)
        mj_size = [size[0], size[1] / 2]
    quat = "" if not any(rpy) else f' quat="{vec(quat_of_rpy(rpy))}"'
    return (f'{indent}<geom type="{kind}" size="{vec(mj_size)}" pos="{vec(xyz)}"{quat}'
            f"{extra}/>")  # fmt: skip


def body_geoms(link: str, indent: str) -> list[str]:
    kind = sheet.link_kind(link)
    mass, com_z, inertia = sheet.INERTIAL[kind]
    material = f' material="{sheet.colour_of(kind)}"'
    lines = [f'{indent}<inertial pos="0 0 {num(com_z)}" mass="{num(mass)}" '
             f'diaginertia="{vec(inertia)}"/>']  # fmt: skip
    for shape in sheet.COLLISION.get(kind, []):
        lines.append(geom_xml(*shape, indent, extra=material))
    return lines


def body_xml(joint: tuple, children: dict[str, list[tuple]], depth: int) -> list[str]:
    name, _parent, child, xyz, rpy, axis, lo, hi = joint
    pad = "  " * depth
    quat = "" if not any(rpy) else f' quat="{vec(quat_of_rpy(rpy))}"'
    _effort, _velocity, damping = sheet.drive(name)
    lines = [
        f'{pad}<body name="{child}" pos="{vec(xyz)}"{quat}>',
        f'{pad}  <joint name="{name}" axis="{vec(axis)}" range="{num(math.radians(lo))} '
        f'{num(math.radians(hi))}" damping="{num(damping)}"/>',
    ]
    lines += body_geoms(child, pad + "  ")
    for sub in children.get(child, []):
        lines += body_xml(sub, children, depth + 1)
    lines.append(f"{pad}</body>")
    return lines


def actuators() -> list[str]:
    lines = []
    for name, *_rest in sheet.all_revolute_joints():
        if name.startswith("WR") or (name[:2].lower() in LONG and name[-1] in "12"):
            continue
        effort = sheet.drive(name)[0]
        lines.append(f'    <position name="A_{name}" joint="{name}" kp="{num(KP)}" kv="{num(KV)}" '
                     f'forcerange="{num(-effort)} {num(effort)}"/>')  # fmt: skip
    for f in LONG:
        F = f.upper()
        lines.append(f'    <position name="A_{F}J0" tendon="{F}J0" kp="{num(KP)}" kv="{num(KV)}" '
                     f'forcerange="{num(-TENDON_EFFORT)} {num(TENDON_EFFORT)}" '
                     f'ctrlrange="0 {num(math.pi)}"/>')  # fmt: skip
    return lines


HEADER = """<!--
  Shadow Dexterous Hand E, right hand: tactile-bullet's own model for MuJoCo.
  GENERATED by tools/make_mjcf.py from the tables of tools/make_urdf.py (docs/hand.md);
  do not edit by hand, edit the scripts and re-run them.

  Frames: the palm body is the world frame (the wrist welded), +z toward the fingertips,
  +x toward the first finger and thumb, -y the grip side; as urdf/shadow_hand.urdf's palm.
  J1/J2 of each long finger: a fixed tendon FFJ0 = FFJ1 + FFJ2 ... driven by one actuator.
-->"""


def build() -> str:
    children: dict[str, list[tuple]] = {}
    for joint in sheet.all_revolute_joints():
        if joint[0].startswith("WR"):
            continue
        children.setdefault(joint[1], []).append(joint)
    wrist_shape = sheet.COLLISION["wrist"][0]
    parts = [
        HEADER,
        '<mujoco model="shadow_hand_e_right">',
        '  <compiler angle="radian" autolimits="true"/>',
        # MuJoCo's default pyramidal friction cone; the solver stops at 1e-5 (default 1e-8):
        # together 25-35% faster steps with the hand closed on a torus or a hyperboloid.
        '  <option timestep="0.002" integrator="implicitfast" tolerance="1e-5"/>',
        # MuJoCo's default arena here is 14.7 MB, allocated and zeroed for every grasp; a
        # closed hand needs under 0.1 MB of it (60 contacts, 250 constraint rows)
        '  <size memory="1M"/>',
        "  <default>",
        f'    <joint armature="{num(ARMATURE)}" limited="true" solreflimit="{vec(LIMIT_SOLREF)}" '
        f'solimplimit="0.99 0.999 0.001"/>',
        '    <geom contype="1" conaffinity="0" condim="3" friction="0.8 0.005 0.0001"/>',
        "  </default>",
        "  <asset>",
    ]
    for name, rgba in sheet.COLOURS.items():
        parts.append(f'    <material name="{name}" rgba="{vec(rgba)}"/>')
    parts += ["  </asset>", "  <worldbody>", '    <body name="palm">']
    parts += body_geoms("palm", "      ")
    wrist = (wrist_shape[0], wrist_shape[1], (0.0, 0.0, -0.034), wrist_shape[3])
    parts.append(geom_xml(*wrist, "      ", extra=' material="dark"'))
    for kind, size, xyz, rpy in sheet.FOREARM_VISUAL:  # visual only, in the palm frame
        at = (xyz[0], xyz[1] + 0.010, xyz[2] - 0.247)
        parts.append(geom_xml(kind, size, at, rpy, "      ",
                              extra=' contype="0" group="1" material="dark"'))  # fmt: skip
    for joint in children["palm"]:
        parts += body_xml(joint, children, 3)
    parts += ["    </body>", "  </worldbody>", "  <tendon>"]
    for f in LONG:
        F = f.upper()
        parts += [
            f'    <fixed name="{F}J0">',
            f'      <joint joint="{F}J2" coef="1"/>',
            f'      <joint joint="{F}J1" coef="1"/>',
            "    </fixed>",
        ]
    parts += ["  </tendon>", "  <actuator>"] + actuators() + ["  </actuator>", "</mujoco>", ""]
    return "\n".join(parts)


def main(argv: list[str] | None = None) -> int:
    return sheet.write_model("MJCF", build, DEFAULT_OUT, argv)


if __name__ == "__main__":
    raise SystemExit(main())
