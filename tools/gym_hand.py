"""A second independently written Shadow hand: gymnasium-robotics' (OpenAI's) MJCF, in the form
``--hand-model`` reads (issue 21's independent-hand test, docs/independent_hand.md).

Farama-Foundation/Gymnasium-Robotics (MIT) ships the Shadow hand OpenAI wrote for its
manipulation tasks (``gymnasium_robotics/envs/assets/hand``: ``robot.xml`` the body tree,
``shared.xml`` its defaults, contact pairs, tendons and actuators). It was written apart from
this project and from the MuJoCo Menagerie's: its own capsules, masses, damping, armature,
friction loss, contact margin, position servos (kp 1 N m/rad) and a distal joint tied rigidly to
the middle one by a short fixed tendon (J1 = 1.14 J2), where the Menagerie's tendon is
underactuated. It is not shipped here; the user brings a copy.

What this tool changes, and only that:

- **Names**: the model uses Shadow's older numbering (FFJ3 .. FFJ0, J0 distal); every joint and
  every reference to one (tendons, actuators, sensors) is renumbered to the current one
  (FFJ4 .. FFJ1, LFJ5, THJ5 .. THJ1, WRJ2, WRJ1), and its actuators with them.
- **The J0 interface**: our controller sends each long finger one target, J1 + J2, as the real
  hand's tendon takes it. The model drives the middle joint alone (its ``A_FFJ1``); that
  actuator becomes ``A_FFJ0`` on a fixed tendon J1 + J2 with the same gain and force range, and
  the model's own coupling tendon still ties the distal joint to the middle one.
- **What needs no mesh**: visual geoms are dropped, and the forearm's convex mesh (no object
  reaches it with the wrist welded). Every collision primitive is kept as written.
- **The wrist's tendons** are dropped: ``--hand-model`` welds the wrist, deleting the joints
  they pull on.
- A model root with the task scenes' options (2 ms, 20 solver iterations, MuJoCo's default
  Euler integrator); no floor, no targets. Materials go with the visual geoms.

Usage: python tools/gym_hand.py GYM/gymnasium_robotics/envs/assets/hand --out HAND.xml (GYM: a
clone of Farama-Foundation/Gymnasium-Robotics), then ``tactile-bullet grasp --engine mujoco
--hand-model HAND.xml ...`` or ``python tools/other_hand_sets.py --hand independent
--hand-model HAND.xml --out DIR``.
"""

from __future__ import annotations

import argparse
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import NoReturn

sys.path.insert(0, str(Path(__file__).resolve().parent))  # mjcf_tools, also when imported
from mjcf_tools import check_out, read_mjcf, write_model  # noqa: E402
from mjcf_tools import fail as _shared_fail  # noqa: E402

LONG = ("FF", "MF", "RF", "LF")
_OLD = re.compile(r"^(robot0:)?(FF|MF|RF|LF|TH|WR)J(\d)$")
_OLD_ACTUATOR = re.compile(r"^(robot0:)?A_(FF|MF|RF|LF|TH|WR)J(\d)$")


def _fail(message: str) -> NoReturn:
    _shared_fail("gym_hand", message)


def renumbered(name: str | None, pattern: re.Pattern = _OLD) -> str | None:
    """A joint (or actuator) name in Shadow's older numbering, one up: ``robot0:FFJ0`` ->
    ``robot0:FFJ1``, ``robot0:LFJ4`` -> ``robot0:LFJ5``; other names unchanged."""
    if not name:
        return name
    m = pattern.match(name)
    if not m:
        return name
    prefix, finger, index = m.group(1) or "", m.group(2), int(m.group(3))
    stem = "A_" if pattern is _OLD_ACTUATOR else ""
    return f"{prefix}{stem}{finger}J{index + 1}"


def _read(path: Path) -> ET.Element:
    return read_mjcf("gym_hand", path).getroot()


def convert(source: Path) -> tuple[ET.ElementTree, list[str]]:
    """The hand of the asset folder ``source`` as one MJCF tree ``--hand-model`` reads, and a
    line per kind of change made."""
    if not source.is_dir():
        _fail(f"{source} is not a folder (give gymnasium_robotics/envs/assets/hand)")
    robot, shared = _read(source / "robot.xml"), _read(source / "shared.xml")
    changes: list[str] = []
    root = ET.Element("mujoco", model="gym_shadow_hand")
    ET.SubElement(root, "compiler", angle="radian")
    ET.SubElement(root, "option", timestep="0.002", iterations="20")
    for tag in ("default", "contact", "tendon", "actuator"):
        for element in shared.findall(tag):
            root.append(element)
    worldbody = ET.SubElement(root, "worldbody")
    for body in robot.findall("body"):
        worldbody.append(body)
    dropped = 0
    for parent in root.iter():
        for geom in list(parent.findall("geom")):
            cls = geom.get("class", "")
            if cls.endswith("D_Vizual") or geom.get("type") == "mesh":
                parent.remove(geom)
                dropped += 1
    changes.append(f"dropped {dropped} visual or mesh geoms")
    for geom in root.iter("geom"):  # materials live in the task's asset file, colour only
        geom.attrib.pop("material", None)
    renamed = 0
    for element in root.iter():
        for attr in ("name", "joint", "joint1", "joint2"):
            if attr != "name" or element.tag == "joint":  # joints, and references to them
                value = element.get(attr)
                new = renumbered(value)
                if new != value:
                    element.set(attr, new)
                    renamed += 1
    changes.append(f"renumbered {renamed} joint names and references")
    _j0_actuators(root, changes)
    tendon = root.find("tendon")
    wrist = [t for t in tendon if any(j.get("joint", "").startswith("robot0:WR") for j in t)]
    for t in wrist:  # the weld deletes the wrist joints they pull on
        tendon.remove(t)
    changes.append(f"dropped the wrist's {len(wrist)} tendons (--hand-model welds the wrist)")
    return ET.ElementTree(root), changes


def _j0_actuators(root: ET.Element, changes: list[str]) -> None:
    """Each long finger's middle-joint servo becomes ``A_xxJ0`` on a tendon J1 + J2 (same gain
    and force range); the other servos take their renumbered names."""
    actuator = root.find("actuator")
    tendon = root.find("tendon")
    if actuator is None or tendon is None:
        _fail("shared.xml has no <actuator> or <tendon> section: not gymnasium-robotics' hand")
    for servo in list(actuator):
        name = servo.get("name", "")
        m = _OLD_ACTUATOR.match(name)
        if not m:
            continue
        prefix, finger, index = m.group(1) or "", m.group(2), int(m.group(3))
        if finger in LONG and index == 1:  # the middle joint's servo (our J2)
            fixed = ET.SubElement(tendon, "fixed", name=f"{prefix}T_{finger}J0")
            ET.SubElement(fixed, "joint", joint=f"{prefix}{finger}J2", coef="1")
            ET.SubElement(fixed, "joint", joint=f"{prefix}{finger}J1", coef="1")
            del servo.attrib["joint"]
            servo.set("tendon", f"{prefix}T_{finger}J0")
            servo.set("ctrlrange", "0 3.1416")
            servo.set("name", f"{prefix}A_{finger}J0")
        else:
            servo.set("name", renumbered(name, _OLD_ACTUATOR))
    changes.append("long fingers' middle-joint servos now drive J1 + J2 (A_xxJ0)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source", help="gymnasium_robotics/envs/assets/hand")
    ap.add_argument("--out", required=True, help="the MJCF file to write")
    ap.add_argument("--force", action="store_true", help="replace --out if it exists")
    args = ap.parse_args()
    out = Path(args.out)
    check_out("gym_hand", out, args.force)
    tree, changes = convert(Path(args.source))
    ET.indent(tree)
    write_model(tree, out, changes, _check_loads)


def _check_loads(out: Path) -> None:
    """The written model is one ``--hand-model`` reads, or the tool exits 2 saying why."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from tactile_bullet.errors import UsageError
    from tactile_bullet.sim.engines.mujoco_hand import load_hand_spec

    try:
        load_hand_spec(out)
    except UsageError as exc:
        _fail(f"the converted model is not one --hand-model reads: {exc}")


if __name__ == "__main__":
    main()
