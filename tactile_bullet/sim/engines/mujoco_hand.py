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


def mjcf_path() -> Path:
    """The project's hand as MJCF, beside the URDF (``hand.urdf_path()``'s folder)."""
    from ...hand import urdf_path

    return urdf_path().with_name("shadow_hand.xml")


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


MAX_MODEL_FILES = 1000
"""Most files a hand model may include or reference (the MuJoCo Menagerie's hand: 28)."""
MODEL_FILES_LIMIT = 256 << 20
"""Most bytes a hand model and every file it includes or references may hold together (each
file is also held to :data:`files.INPUT_LIMITS`' 64 MiB for a hand model)."""
_FILE_ATTRIBUTES = {
    "include": ("file",),
    "model": ("file",),
    "mesh": ("file",),
    "hfield": ("file",),
    "skin": ("file",),
    "texture": ("file", "fileright", "fileleft", "fileup", "filedown", "filefront",
                "fileback"),
}  # fmt: skip
"""The MJCF elements that name a file, and the attributes that do."""


def model_files(path: str | Path) -> dict[str, Path]:
    """The model file and every file it includes or references (``<include>``, meshes,
    textures, height fields, skins, attached models), by their names relative to the model's
    folder, each checked by the one rule every input keeps (:func:`files.referenced_file`): a
    regular file (a FIFO is never opened), inside the model's folder (as a glTF's buffers must
    sit beside it), at most 64 MiB, and :data:`MODEL_FILES_LIMIT` bytes together. MuJoCo
    resolves every relative name against the top model's folder (``meshdir``, ``texturedir``
    and ``assetdir`` too), and so does this. A UsageError names the first file refused."""
    import xml.etree.ElementTree as ET

    from ...files import input_path, read_input_text, referenced_file

    top = input_path(path, "hand model")
    folder = top.resolve().parent
    found: dict[str, Path] = {top.name: top}
    dirs: dict[str, str] = {}
    assets: list[tuple[str, str, str]] = []  # (element, name, the file naming it)
    todo = [(top, top.name)]
    while todo:
        current, label = todo.pop(0)
        try:
            root = ET.fromstring(read_input_text(current, "hand model"))
        except (ET.ParseError, UnicodeDecodeError) as exc:
            why = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise UsageError(f"--hand-model {path}: {label} is not an MJCF file MuJoCo can "
                             f"read ({why})") from None  # fmt: skip
        for element in root.iter():
            tag = element.tag if isinstance(element.tag, str) else ""
            if tag == "compiler":
                dirs.update({k: v for k, v in element.attrib.items()
                             if k in ("meshdir", "texturedir", "assetdir")})  # fmt: skip
            for attribute in _FILE_ATTRIBUTES.get(tag, ()):
                name = element.get(attribute)
                if not name:
                    continue
                if tag == "include":
                    target = referenced_file(folder, name, f"--hand-model {path}: {label}",
                                             "hand model", what="include")  # fmt: skip
                    key = target.relative_to(folder).as_posix()
                    if key not in found:
                        found[key] = target
                        todo.append((target, key))
                else:
                    assets.append((tag, name, label))
            if len(found) + len(assets) > MAX_MODEL_FILES:
                raise UsageError(f"--hand-model {path} includes or references over "
                                 f"{MAX_MODEL_FILES:,} files")  # fmt: skip
    for tag, name, label in assets:
        kind = "texturedir" if tag == "texture" else "meshdir" if tag != "model" else None
        base = dirs.get(kind, dirs.get("assetdir", "")) if kind else ""
        target = referenced_file(folder, str(Path(base) / name) if base else name,
                                 f"--hand-model {path}: {label}", "hand model",
                                 what=tag)  # fmt: skip
        found.setdefault(target.relative_to(folder).as_posix(), target)
    total = sum(p.stat().st_size for p in found.values())
    if total > MODEL_FILES_LIMIT:
        raise UsageError(f"--hand-model {path} and the files it references hold {total:,} "
                         f"bytes, over the {MODEL_FILES_LIMIT:,}-byte limit")  # fmt: skip
    return found


def model_digest(path: str | Path) -> tuple[str, dict[str, str]]:
    """sha256 of the hand model's content, over the model file and everything it includes or
    references (:func:`model_files`), and each file's own sha256 by its name: what a record
    and a dataset keep of the hand that made them (``ControllerSettings.hand_model_digest``)."""
    import hashlib

    each: dict[str, str] = {}
    whole = hashlib.sha256()
    for name, file in sorted(model_files(path).items()):
        h = hashlib.sha256()
        try:
            with open(file, "rb") as fh:
                while block := fh.read(1 << 20):
                    h.update(block)
        except OSError as exc:
            raise UsageError(f"cannot read {file}: {exc.strerror or exc}") from None
        each[name] = h.hexdigest()
        whole.update(f"{name}\0{each[name]}\n".encode())
    return whole.hexdigest(), each


def with_digest(controller):
    """``controller`` (``ControllerSettings``) carrying its hand model's content digest, taken
    now where it has none; one it carries must still be the model's (a UsageError names the
    file otherwise)."""
    from dataclasses import replace

    if controller.hand_model is None:
        return controller
    digest, _ = model_digest(controller.hand_model)
    if controller.hand_model_digest not in (None, digest):
        raise UsageError(
            f"hand model {controller.hand_model} changed since its digest "
            f"{controller.hand_model_digest[:12]} was taken (now {digest[:12]})"
        )
    return replace(controller, hand_model_digest=digest)


def load_hand_spec(path: str | Path, digest: str | None = None):
    """The model at ``path`` as an MjSpec with its wrist welded; a UsageError naming the file
    or the first missing joint, actuator or the palm body, an actuator that drives another
    joint than its name says, or a parameter that is not a finite number, otherwise. Every
    file it includes or references is checked first (:func:`model_files`); with ``digest``,
    its content must still be the one a dataset or record was made with."""
    import mujoco

    from ...files import input_path

    path = input_path(path, "hand model")  # stat only: a FIFO or device is never opened
    if path.suffix.lower() != ".xml":
        raise UsageError(f"--hand-model {path} is not an MJCF model file (.xml)")
    if digest is not None:
        now, _ = model_digest(path)
        if now != digest:
            raise UsageError(
                f"--hand-model {path} changed since this grasp's settings were made (its "
                f"content digest is {now[:12]}, not {digest[:12]}): not mixing two hands"
            )
    else:
        model_files(path)
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
    _check_actuators(model, actuators, path)
    _check_finite(model, path)
    _weld_wrist(spec)
    return spec


def driven_joints(model, actuator: int) -> set[str]:
    """The Shadow names of the joints an actuator drives: its joint's, or its tendon's."""
    import mujoco

    kind, target = int(model.actuator_trntype[actuator]), int(model.actuator_trnid[actuator, 0])
    joint = mujoco.mjtObj.mjOBJ_JOINT
    if kind in (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)):
        ids = [target]
    elif kind == int(mujoco.mjtTrn.mjTRN_TENDON):
        adr, num = model.tendon_adr[target], model.tendon_num[target]
        ids = [int(model.wrap_objid[w]) for w in range(adr, adr + num)
               if int(model.wrap_type[w]) == int(mujoco.mjtWrap.mjWRAP_JOINT)]  # fmt: skip
    else:
        ids = []
    return {shadow_name(mujoco.mj_id2name(model, joint, i), "joint") or "?" for i in ids}


def _check_actuators(model, actuators: dict[str, int], path) -> None:
    """Each required actuator drives the joint its name says (``A_FFJ3`` FFJ3; ``A_FFJ0`` a
    tendon over FFJ1 and FFJ2): one named for a joint and wired to another would close the
    wrong joint while the grasp reads the right one."""
    for name in REQUIRED_ACTUATORS:
        joint = name[2:]
        want = {joint[:-1] + "1", joint[:-1] + "2"} if joint.endswith("0") else {joint}
        got = driven_joints(model, actuators[name])
        if got != want:
            drives, named = " + ".join(sorted(got)) or "no joint", " + ".join(sorted(want))
            raise UsageError(f"--hand-model {path}: actuator {name} drives {drives}, not "
                             f"{named} as its name says (docs/engines.md)")  # fmt: skip


def _check_finite(model, path) -> None:
    """Every number of the compiled model is finite: a ``kp="nan"`` or an infinite mass makes
    every grasp's angles NaN."""
    import numpy as np

    for field in sorted(dir(model)):
        if field.startswith("_"):
            continue
        try:
            value = getattr(model, field)
        except Exception:  # noqa: BLE001, S112 - a property mujoco cannot give: not a number
            continue
        if isinstance(value, np.ndarray) and value.dtype.kind == "f" and value.size and (
            not np.all(np.isfinite(value))
        ):
            raise UsageError(f"--hand-model {path}: its {field} holds a value that is not a "
                             "finite number (NaN or infinite)")  # fmt: skip


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
