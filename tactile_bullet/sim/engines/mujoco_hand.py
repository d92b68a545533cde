"""Reading a Shadow hand out of any MJCF model by Shadow's names (``--hand-model FILE.xml``).

A model qualifies when, after an optional prefix ending in ``_`` or ``:`` (``rh_`` in the MuJoCo
Menagerie's model, ``robot0:`` in gymnasium-robotics'), it has:

- the joints of :data:`REQUIRED_JOINTS` (Shadow's current numbering: FFJ4 .. FFJ1, LFJ5,
  THJ5 .. THJ1; J1 the distal joint). Wrist joints (WRJ2, WRJ1) are optional and welded at 0;
- a position-style actuator on each of :data:`REQUIRED_ACTUATORS`: ``A_FFJ4``, ``A_FFJ3``, ...,
  ``A_LFJ5``, ``A_THJ5`` .. ``A_THJ1``, and ``A_FFJ0`` .. ``A_LFJ0`` driving each long
  finger's J1 + J2 (a tendon, as the real hand's);
- a body named ``palm``: the object is placed in its frame, and contacts are reported in it.

Hand bodies are matched to the project's link names the same way (``rh_ffdistal`` is
``ffdistal``). A model with the older numbering (FFJ3 .. FFJ0, J0 the distal joint) names
different joints by the same words and is refused for the first it lacks: rename its joints
first.
"""

from __future__ import annotations

import re
from pathlib import Path

from ...errors import UsageError
from ...hand import JOINT_NAMES, LONG_FINGERS

REQUIRED_JOINTS: tuple[str, ...] = tuple(n for n in JOINT_NAMES if not n.startswith("WR"))
REQUIRED_ACTUATORS: tuple[str, ...] = tuple(
    [f"A_{n}" for n in REQUIRED_JOINTS if n.startswith("TH") or n[-1] in "345"]
    + [f"A_{f.upper()}J0" for f in LONG_FINGERS]
)
WRIST_JOINTS = ("WRJ2", "WRJ1")

_JOINT = re.compile(r"^(?:.*[_:])?((?:FF|MF|RF|LF|TH|WR)J\d)$")
_ACTUATOR = re.compile(r"^(?:.*[_:])?(A_(?:FF|MF|RF|LF|TH|WR)J\d)$")
_BODY = re.compile(r"^(?:.*[_:])?([a-z]+)$")


def shadow_name(name: str | None, kind: str) -> str | None:
    """The Shadow name a model's element answers to (None: none)."""
    if not name:
        return None
    pattern = {"joint": _JOINT, "actuator": _ACTUATOR, "body": _BODY}[kind]
    match = pattern.match(name)
    return match.group(1) if match else None


def name_map(model, kind: str) -> dict[str, int]:
    """Shadow name -> element id for every element of ``kind`` (joint, actuator, body)."""
    import mujoco

    obj = {"joint": mujoco.mjtObj.mjOBJ_JOINT, "actuator": mujoco.mjtObj.mjOBJ_ACTUATOR,
           "body": mujoco.mjtObj.mjOBJ_BODY}[kind]  # fmt: skip
    count = {"joint": model.njnt, "actuator": model.nu, "body": model.nbody}[kind]
    out: dict[str, int] = {}
    for i in range(count):
        short = shadow_name(mujoco.mj_id2name(model, obj, i), kind)
        if short is not None and short not in out:
            out[short] = i
    return out


def load_hand_spec(path: str | Path):
    """The model at ``path`` as an MjSpec with its wrist welded; a UsageError naming the file
    or the first missing joint, actuator or the palm body otherwise."""
    import mujoco

    from ...files import input_path

    path = input_path(path, "hand model")  # stat only: a FIFO or device is never opened
    if path.suffix.lower() != ".xml":
        raise UsageError(f"--hand-model {path} is not an MJCF model file (.xml)")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        model = spec.compile()
    except Exception as exc:  # noqa: BLE001 - mujoco raises ValueError with the parser's text
        why = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UsageError(f"--hand-model {path} is not a model MuJoCo can load: {why}") from None
    joints, actuators = name_map(model, "joint"), name_map(model, "actuator")
    for name in REQUIRED_JOINTS:
        if name not in joints:
            raise UsageError(f"--hand-model {path} has no joint {name} (docs/engines.md)")
    for name in REQUIRED_ACTUATORS:
        if name not in actuators:
            raise UsageError(f"--hand-model {path} has no actuator {name} (docs/engines.md)")
    if "palm" not in name_map(model, "body"):
        raise UsageError(f"--hand-model {path} has no body named palm (docs/engines.md)")
    _weld_wrist(spec)
    return spec


def _weld_wrist(spec) -> None:
    """Delete the wrist's joints (and whatever drives them): the palm joins its parent, as on
    the thesis' mounted hand."""
    for actuator in list(spec.actuators):
        if (shadow_name(actuator.name, "actuator") or "").startswith("A_WR") or (
            shadow_name(actuator.target, "joint") or ""
        ).startswith("WR"):
            spec.delete(actuator)
    before = _static_bodies(spec)
    for joint in list(spec.joints):
        if shadow_name(joint.name, "joint") in WRIST_JOINTS:
            spec.delete(joint)
    # MuJoCo skips contacts between a body and its parent, unless the parent is welded to the
    # world: with the wrist welded, the palm's knuckles would start the grasp pressed into the
    # palm (a model written with a moving wrist lets them overlap it). Keep the skip the model
    # had for every parent the weld made static.
    for parent in _static_bodies(spec) - before:
        body = spec.body(parent)
        for child in body.bodies:
            if child.joints:
                spec.add_exclude(bodyname1=parent, bodyname2=child.name)


def _static_bodies(spec) -> set[str]:
    """Names of the bodies welded to the world (no joint between them and it), the world
    excluded."""
    out: set[str] = set()
    todo = [b for b in spec.worldbody.bodies if not b.joints]
    while todo:
        body = todo.pop()
        out.add(body.name)
        todo += [b for b in body.bodies if not b.joints]
    return out
