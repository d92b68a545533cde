"""A collision-only copy of an independently written Shadow hand model, for the issue 21
independent-hand test (docs/independent_hand.md).

The MuJoCo Menagerie's ``shadow_hand/right_hand.xml`` (google-deepmind/mujoco_menagerie,
Apache-2.0) was written apart from this project: its own collision geometry, masses, joint
damping, friction loss, armature, actuator gains (kp 1, 0.5 on the J1 + J2 tendon), force
ranges, contact softness and solver options. It is not shipped here; the user brings a copy.

Its meshes are large and not always at hand (a sparse checkout, an index that stores only the
XML). This tool writes a copy that needs none of them:

- visual geoms (``contype="0"`` and ``conaffinity="0"``, or a class named ``*visual*``) are
  dropped: they never touch anything;
- a collision geom whose mesh file is missing is replaced by the primitive in
  :data:`STAND_INS` (the fingertip pads as capsules of the real pads' size), or dropped when
  the table says so (the forearm's, which no grasped object reaches with the wrist welded);
- everything else (bodies, joints, inertias, defaults, tendons, actuators, options) is kept
  exactly as written.

Usage: python tools/independent_hand.py MENAGERIE/shadow_hand/right_hand.xml --out HAND.xml
then ``tactile-bullet grasp --engine mujoco --hand-model HAND.xml ...``, or
``python tools/other_hand_sets.py --hand-model HAND.xml --out DIR``.
"""

from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import NoReturn

sys.path.insert(0, str(Path(__file__).resolve().parent))  # mjcf_tools, also when imported
from mjcf_tools import check_out, read_mjcf, write_model  # noqa: E402
from mjcf_tools import fail as _shared_fail  # noqa: E402

STAND_INS: dict[str, dict[str, str] | None] = {
    # Shadow's long-finger distal: 26 mm from the J1 axis to the tip, an 17 mm wide pad
    "f_distal_pst": {"type": "capsule", "size": "0.0085 0.008", "pos": "0 0 0.011"},
    # the thumb's distal: ~31 mm to the tip, a 19 mm pad
    "th_distal_pst": {"type": "capsule", "size": "0.0095 0.009", "pos": "0 0 0.013"},
    "forearm_collision": None,
}
"""Missing mesh -> the primitive standing in for it (None: drop the geom)."""


def _fail(message: str) -> NoReturn:
    _shared_fail("independent_hand", message)


def _is_visual(geom: ET.Element) -> bool:
    cls = geom.get("class", "")
    return "visual" in cls or (geom.get("contype") == "0" and geom.get("conaffinity") == "0")


def collision_copy(source: Path) -> tuple[ET.ElementTree, list[str]]:
    """The model at ``source`` without its visual geoms, missing meshes replaced; and a line
    per change made."""
    tree = read_mjcf("independent_hand", source)
    root = tree.getroot()
    if root.tag != "mujoco":
        _fail(f"{source} is not an MJCF model (its root element is <{root.tag}>, not <mujoco>)")
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
                _fail(f"collision mesh {mesh!r} is missing and has no stand-in "
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model", help="the Menagerie's shadow_hand/right_hand.xml")
    ap.add_argument("--out", required=True, help="where to write the collision-only copy")
    ap.add_argument("--force", action="store_true", help="replace --out if it exists")
    args = ap.parse_args()
    out = Path(args.out)
    check_out("independent_hand", out, args.force)
    tree, changes = collision_copy(Path(args.model))
    write_model(tree, out, changes, None)


if __name__ == "__main__":
    main()
