"""Another Shadow hand's MJCF as one model file ``--hand-model`` reads (``convert-hand``).

Two independently written Shadow hands are known, each in its own layout (the
independent-hand test, docs/independent_hand.md); neither is shipped here, the user brings a
copy:

- ``menagerie``: the MuJoCo Menagerie's ``shadow_hand/right_hand.xml``
  (google-deepmind/mujoco_menagerie, Apache-2.0), one file. Its own collision geometry,
  masses, joint damping, friction loss, armature, actuator gains (kp 1, 0.5 on the J1 + J2
  tendon), force ranges, contact softness and solver options. Its meshes are large and not
  always at hand (a sparse checkout, an index that stores only the XML), so
  :func:`collision_copy` writes a copy that needs none of them: visual geoms
  (``contype="0"`` and ``conaffinity="0"``, or a class named ``*visual*``) are dropped; a
  collision geom whose mesh file is missing is replaced by the primitive in
  :data:`STAND_INS` (the fingertip pads as capsules of the real pads' size), or dropped where
  the table says so (the forearm's, which no grasped object reaches with the wrist welded);
  everything else (bodies, joints, inertias, defaults, tendons, actuators, options) is kept
  exactly as written.
- ``gymnasium``: the hand OpenAI wrote for its manipulation tasks, as
  Farama-Foundation/Gymnasium-Robotics (MIT) ships it: the folder
  ``gymnasium_robotics/envs/assets/hand`` (``robot.xml`` the body tree, ``shared.xml`` its
  defaults, contact pairs, tendons and actuators). Its own capsules, masses, damping,
  armature, friction loss, contact margin, position servos (kp 1 N m/rad) and a distal joint
  tied rigidly to the middle one by a short fixed tendon (J1 = 1.14 J2), where the
  Menagerie's tendon is underactuated. :func:`from_gymnasium` changes only this:

  - **Names**: the model uses Shadow's older numbering (FFJ3 .. FFJ0, J0 distal); every joint
    and every reference to one (tendons, actuators, sensors) is renumbered to the current one
    (FFJ4 .. FFJ1, LFJ5, THJ5 .. THJ1, WRJ2, WRJ1), and its actuators with them.
  - **The J0 interface**: our controller sends each long finger one target, J1 + J2, as the
    real hand's tendon takes it. The model drives the middle joint alone (its ``A_FFJ1``);
    that actuator becomes ``A_FFJ0`` on a fixed tendon J1 + J2 with the same gain and force
    range, and the model's own coupling tendon still ties the distal joint to the middle one.
  - **What needs no mesh**: visual geoms are dropped, and the forearm's convex mesh (no object
    reaches it with the wrist welded). Every collision primitive is kept as written.
  - **The wrist's tendons** are dropped: ``--hand-model`` welds the wrist, deleting the
    joints they pull on.
  - A model root with the task scenes' options (2 ms, 20 solver iterations, MuJoCo's default
    Euler integrator); no floor, no targets. Materials go with the visual geoms.

Bad input is a :class:`~tactile_bullet.errors.UsageError` naming the file and why.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from ..errors import UsageError

LAYOUTS: tuple[str, ...] = ("menagerie", "gymnasium")
"""The layouts :func:`convert_hand` reads (``auto`` picks one from the source)."""

GYMNASIUM_FILES: tuple[str, ...] = ("robot.xml", "shared.xml")
"""What a gymnasium-robotics hand folder holds: the body tree, then everything else."""

STAND_INS: dict[str, dict[str, str] | None] = {
    # Shadow's long-finger distal: 26 mm from the J1 axis to the tip, an 17 mm wide pad
    "f_distal_pst": {"type": "capsule", "size": "0.0085 0.008", "pos": "0 0 0.011"},
    # the thumb's distal: ~31 mm to the tip, a 19 mm pad
    "th_distal_pst": {"type": "capsule", "size": "0.0095 0.009", "pos": "0 0 0.013"},
    "forearm_collision": None,
}
"""Missing mesh -> the primitive standing in for it (None: drop the geom)."""

LONG = ("FF", "MF", "RF", "LF")
_OLD = re.compile(r"^(robot0:)?(FF|MF|RF|LF|TH|WR)J(\d)$")
_OLD_ACTUATOR = re.compile(r"^(robot0:)?A_(FF|MF|RF|LF|TH|WR)J(\d)$")


@dataclass(frozen=True)
class Conversion:
    """A converted hand: the MJCF tree to write, the layout it was read as, and a line per
    change made."""

    tree: ET.ElementTree
    layout: str
    changes: tuple[str, ...]


# --- reading ---------------------------------------------------------------------------------


def read_mjcf(path: Path) -> ET.ElementTree:
    """The parsed file (checked first as every input is: a regular file under the hand
    model's size limit), or a UsageError naming why it cannot be read."""
    from ..files import input_path

    path = input_path(path, "hand model")
    try:
        return ET.parse(path)
    except (OSError, ET.ParseError) as exc:
        raise UsageError(f"{path} is not a readable MJCF file: {exc}") from None


def detect_layout(source: str | os.PathLike, layout: str = "auto") -> str:
    """The layout of ``source`` (``layout`` checked against it where named): a folder holding
    :data:`GYMNASIUM_FILES` is gymnasium-robotics', a file the Menagerie's. Only ``stat`` is
    called: a missing path, a folder of another kind or a special file is refused before any
    file is read."""
    from ..files import input_path

    source = Path(source)
    if layout not in ("auto", *LAYOUTS):
        raise UsageError(f"unknown layout {layout!r} (layouts: auto, {', '.join(LAYOUTS)})")
    if layout == "gymnasium" or (layout == "auto" and source.is_dir()):
        if not source.is_dir():
            raise UsageError(
                f"{source} is not a folder (give gymnasium_robotics/envs/assets/hand)"
            )
        for name in GYMNASIUM_FILES:
            input_path(source / name, "hand model")
        return "gymnasium"
    if source.is_dir():
        raise UsageError(
            f"{source} is a folder: the menagerie layout is one file "
            "(give shadow_hand/right_hand.xml)"
        )
    input_path(source, "hand model")
    return "menagerie"


def convert_hand(source: str | os.PathLike, layout: str = "auto") -> Conversion:
    """The hand at ``source`` (a Menagerie file or a gymnasium-robotics folder) as one MJCF
    tree ``--hand-model`` reads."""
    source = Path(source)
    layout = detect_layout(source, layout)
    if layout == "gymnasium":
        tree, changes = from_gymnasium(source)
        ET.indent(tree)
    else:
        tree, changes = collision_copy(source)
        _check_names(tree, source)
    return Conversion(tree, layout, tuple(changes))


def _check_names(tree: ET.ElementTree, source: Path) -> None:
    """Refuse a file that is not a Shadow hand before anything is written (the Menagerie's
    copy is not compiled here: its meshes resolve beside the source): every joint and
    actuator ``--hand-model`` drives, and a palm, must be there by their Shadow names."""
    from .engines.mujoco_hand import REQUIRED_ACTUATORS, REQUIRED_JOINTS, shadow_name

    root = tree.getroot()
    for kind, tag, wanted in (("joint", "joint", REQUIRED_JOINTS),
                              ("actuator", None, REQUIRED_ACTUATORS)):  # fmt: skip
        elements = root.iter(tag) if tag else (e for a in root.iter("actuator") for e in a)
        have = {shadow_name(e.get("name"), kind) for e in elements}
        missing = [n for n in wanted if n not in have]
        if missing:
            raise UsageError(
                f"{source} is not a Shadow hand --hand-model can drive: it has no {kind} "
                f"{missing[0]}{f' (nor {len(missing) - 1} more)' if len(missing) > 1 else ''}"
            )
    if "palm" not in {shadow_name(b.get("name"), "body") for b in root.iter("body")}:
        raise UsageError(f"{source} is not a Shadow hand --hand-model can drive: no palm body")


def write_hand(conversion: Conversion, out: str | os.PathLike) -> Path:
    """Write the converted model to ``out`` (atomically: a model that fails its check is never
    left there). A gymnasium-robotics conversion is loaded as ``--hand-model`` loads it first,
    a UsageError saying why where it cannot be (the Menagerie's copy keeps the model's own
    mesh references, which resolve beside the source, so it is written as converted)."""
    from ..files import atomic_path

    out = Path(out)
    with atomic_path(out, "--out") as tmp:
        conversion.tree.write(tmp, encoding="unicode")
        if conversion.layout == "gymnasium":
            _check_loads(tmp, out)
    return out


def _check_loads(path: Path, out: Path) -> None:
    from .engines.mujoco_hand import load_hand_spec

    try:
        load_hand_spec(path)
    except UsageError as exc:
        why = str(exc).replace(str(path), str(out))
        raise UsageError(f"the converted model is not one --hand-model reads: {why}") from None


# --- the MuJoCo Menagerie's hand -------------------------------------------------------------


def _is_visual(geom: ET.Element) -> bool:
    cls = geom.get("class", "")
    return "visual" in cls or (geom.get("contype") == "0" and geom.get("conaffinity") == "0")


def collision_copy(source: Path) -> tuple[ET.ElementTree, list[str]]:
    """The model at ``source`` without its visual geoms, missing meshes replaced; and a line
    per change made."""
    source = Path(source)
    tree = read_mjcf(source)
    root = tree.getroot()
    if root.tag != "mujoco":
        raise UsageError(
            f"{source} is not an MJCF model (its root element is <{root.tag}>, not <mujoco>)"
        )
    compiler = root.find("compiler")
    meshdir = source.parent / (compiler.get("meshdir", "") if compiler is not None else "")
    missing = set()
    asset = root.find("asset")
    if asset is not None:
        for mesh in list(asset.findall("mesh")):
            file = mesh.get("file", "")
            name = mesh.get("name") or Path(file).stem
            if not (meshdir / file).is_file():
                missing.add(name)
                asset.remove(mesh)
    changes = []
    for parent in root.iter():
        for geom in list(parent.findall("geom")):
            mesh = geom.get("mesh")
            if _is_visual(geom):
                parent.remove(geom)
                continue
            if mesh is None or mesh not in missing:
                continue
            if mesh not in STAND_INS:
                raise UsageError(f"collision mesh {mesh!r} is missing and has no stand-in "
                                 f"(known: {', '.join(STAND_INS)})")  # fmt: skip
            body = parent.get("name", "?")
            stand_in = STAND_INS[mesh]
            if stand_in is None:
                parent.remove(geom)
                changes.append(f"{body}: dropped the {mesh} collision mesh")
                continue
            del geom.attrib["mesh"]
            geom.attrib.update(stand_in)
            changes.append(f"{body}: {mesh} -> {stand_in['type']} {stand_in['size']}")
    used = {g.get("material") for g in root.iter("geom")}
    for material in [] if asset is None else asset.findall("material"):
        if material.get("name") not in used:
            asset.remove(material)  # only the dropped visual geoms used it
    return tree, changes


# --- gymnasium-robotics' hand ----------------------------------------------------------------


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


def from_gymnasium(source: Path) -> tuple[ET.ElementTree, list[str]]:
    """The hand of the asset folder ``source`` as one MJCF tree ``--hand-model`` reads, and a
    line per kind of change made."""
    source = Path(source)
    if not source.is_dir():
        raise UsageError(f"{source} is not a folder (give gymnasium_robotics/envs/assets/hand)")
    robot = read_mjcf(source / "robot.xml").getroot()
    shared = read_mjcf(source / "shared.xml").getroot()
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
        raise UsageError(
            "shared.xml has no <actuator> or <tendon> section: not gymnasium-robotics' hand"
        )
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
