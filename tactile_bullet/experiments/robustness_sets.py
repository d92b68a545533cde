"""The robustness matrix's test conditions: the sets each column and training reads, the
household and out-of-family objects, and how a column's grasps are read (as simulated, through
a sensor model, or exported as a hand's CSV and imported back). The rule and the scoring are
:mod:`.robustness`; docs/robustness.md declares both.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import UsageError
from ..records import ControllerSettings, GraspRecord
from . import protocols as P

SHAPES = P.SHAPES

SCALES: dict[str, tuple[int, int, int]] = {"full": (48, 24, 12), "quick": (12, 6, 4),
                                           "tiny": (4, 2, 1)}  # fmt: skip
"""Grasps per shape (training sets, each test column) and per household object, by scale."""

FAMILY_OBJECTS: dict[str, str] = {"can": "cylinder", "ball": "sphere", "vase": "hyperboloid",
                                  "cup": "cone"}  # fmt: skip
"""Household meshes a person would call one of the families (decided before scoring)."""
AMBIGUOUS_OBJECTS: tuple[str, ...] = ("bottle", "mug_body")
"""Left out: a person could call them a family or none (a necked bottle, a tapered mug)."""
NO_FAMILY_OBJECTS: tuple[str, ...] = ("bowl", "egg", "pear", "spool", "box", "banana",
                                      "hex_prism", "soap")  # fmt: skip
"""Household meshes of no family: the out-of-family column's meshes."""
OUT_OF_FAMILY_SHAPES: tuple[str, ...] = ("ovoid", "hexagonal_pyramid")
"""The thesis' modified shapes; every plugin shape that is no thesis family joins them."""

OTHER_HANDS: tuple[str, ...] = ("menagerie", "gymnasium")
"""Hands written by others, each a column when ``--other-hand NAME=FILE`` gives its model."""
OTHER_HAND_FRACTIONS = (0.1, 0.3, 0.5, 0.7, 0.9)
OTHER_HAND_X = (-0.010, -0.005, 0.0, 0.005, 0.010)
OTHER_HAND_Z = (-0.005, 0.0, 0.0025, 0.005)
TURNED_DEG = (0.0, 5.0, 10.0, 15.0, 20.0, 25.0)
NOISE = P.NOISE_LEVELS[[n for n, *_ in P.NOISE_LEVELS].index("sigma 1 deg + bias 3 deg")][1]


@dataclass(frozen=True)
class Column:
    """One test condition: the sets it reads and how they are read (``as-is``, ``noise``,
    ``csv``: exported as a hand's CSV and imported, ``j0-only``: the same with J0 only)."""

    name: str
    description: str
    sets: tuple[str, ...]
    read: str = "as-is"
    hand: str | None = None
    """The other hand whose model the column needs (None: ours)."""


COLUMNS: tuple[Column, ...] = (
    Column("sizes", "our hand, Bullet: sizes within 1/16 of each range's ends", ("sizes",)),
    Column("poses", "our hand, Bullet: offsets +-10 mm and rotations 5-25 deg", ("poses",)),
    Column("turned", "our hand, Bullet: held-out sizes turned 0-25 deg", ("turned",)),
    Column("noise", "our hand, Bullet: 1 deg joint noise + 3 deg calibration bias",
           ("test",), "noise"),  # fmt: skip
    Column("shift", "our hand, Bullet: every physics knob +-20%", ("shift-up", "shift-down")),
    Column("equal-split", "our hand, Bullet: J1 and J2 share the bend (equal-torque tendon)",
           ("equal-split",)),  # fmt: skip
    Column("mujoco", "our MJCF hand, MuJoCo", ("mujoco-test",)),
    Column("menagerie", "the Menagerie's Shadow hand, MuJoCo, replayed as a CSV",
           ("menagerie",), "csv", "menagerie"),  # fmt: skip
    Column("gymnasium", "gymnasium-robotics' Shadow hand, MuJoCo, replayed as a CSV",
           ("gymnasium",), "csv", "gymnasium"),  # fmt: skip
    Column("household", "our hand, Bullet: can, ball, vase, paper cup meshes, turned 0-25 deg",
           ("household",)),  # fmt: skip
    Column("j0-only", "our hand, Bullet: held-out grasps imported from a J0-only CSV",
           ("test",), "j0-only"),  # fmt: skip
)
COLUMN_NAMES: tuple[str, ...] = tuple(c.name for c in COLUMNS)
OUT_OF_FAMILY = "out-of-family"

TRAININGS: dict[str, tuple[str, ...]] = {
    "bullet": ("bullet-train",),
    "bullet-randomized": ("bullet-train-randomized",),
    "mujoco-randomized": ("mujoco-train-randomized",),
    "both-randomized": ("bullet-train-randomized", "mujoco-train-randomized"),
    "posed-randomized": ("bullet-posed-randomized", "mujoco-posed-randomized"),
    "both+posed-randomized": ("bullet-train-randomized", "mujoco-train-randomized",
                              "bullet-posed-randomized", "mujoco-posed-randomized"),
    "both+posed-noise-aware": ("bullet-train-randomized", "mujoco-train-randomized",
                               "bullet-posed-randomized", "mujoco-posed-randomized"),
    "none": ("bullet-train",),
}
"""Training name -> the sets it joins (``none``: the training-free shape fit, which is fitted
on the Bullet set only to learn its class names)."""
RANDOMIZED = ("bullet-randomized", "mujoco-randomized", "both-randomized", "posed-randomized",
              "both+posed-randomized", "both+posed-noise-aware")
NOISE_AWARE = frozenset({"both+posed-noise-aware"})
"""Trainings whose records are also presented through joint noise (``train --training
noise-aware``'s augmentation, learn/robust.py), added in the second replicate run."""
TRAINING_SETS = frozenset(s for sets in TRAININGS.values() for s in sets)
"""The sets models are fitted on: a replicate run (``--replicate``) draws every other set
afresh and keeps these."""
REPLICATE_SEED_STEP = 1000
LEARNT = ("bullet", *RANDOMIZED)


POSED_X = (-0.010, -0.005, 0.0, 0.005, 0.010)
POSED_Z = (-0.010, -0.005, 0.0, 0.005, 0.010)
"""Offsets (m) of the posed training recipe (added after the first full run, docs/robustness.md);
its rotations are :data:`TURNED_DEG`."""

# --- the sets -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepSet:
    """A set given as a sweep table (meshes, modified shapes): what ``simulate_sets`` reads."""

    name: str
    table: dict[str, Any]
    seed: int
    base: str | None = None

    def sweep(self):
        from ..datasets.sweeps import Sweep

        return Sweep.from_dict(self.table, f"set {self.name}",
                               Path(self.base) if self.base else None)  # fmt: skip


def _tag(scale: str) -> str:
    return "robust-" + ("" if scale == "full" else f"{scale}-")


def set_specs(
    scale: str, hands: Mapping[str, str], objects: Path | None, plugin_shapes: Sequence[str] = (),
    replicate: int = 0,
) -> dict[str, Any]:
    """Every set the matrix reads, by short name (columns and trainings name them so): each a
    :class:`protocols.SetSpec` or a :class:`SweepSet` whose ``name`` is its cache folder.
    ``replicate`` k > 0 draws every set that is not a training set afresh: its seed plus
    k x :data:`REPLICATE_SEED_STEP`, its folder suffixed ``-rK`` (docs/robustness.md)."""
    out = _set_specs(scale, hands, objects, plugin_shapes)
    if replicate:
        for short, spec in out.items():
            if short not in TRAINING_SETS:
                out[short] = replace(spec, name=f"{spec.name}-r{replicate}",
                                     seed=spec.seed + replicate * REPLICATE_SEED_STEP)  # fmt: skip
    return out


def _set_specs(
    scale: str, hands: Mapping[str, str], objects: Path | None, plugin_shapes: Sequence[str] = ()
) -> dict[str, Any]:
    from ..datasets.randomize import Randomization, randomized_table

    n_train, n_test, n_object = SCALES[scale]
    tag = _tag(scale)
    bullet, mujoco = ControllerSettings(), ControllerSettings(engine="mujoco")

    def spec(short, per_shape, fractions, xs, zs, seed, controller=bullet, **kw):
        return short, P.SetSpec(f"{tag}{short}", per_shape, fractions, xs, zs,
                                controller=controller, seed=seed, **kw)  # fmt: skip

    out = dict([
        spec("bullet-train", n_train, P.TRAIN_FRACTIONS, P.TRAIN_X, P.TRAIN_Z, 101),
        spec("mujoco-train", n_train, P.TRAIN_FRACTIONS, P.TRAIN_X, P.TRAIN_Z, 101, mujoco),
        spec("test", n_test, P.TEST_FRACTIONS, P.TEST_X, P.TEST_Z, 102),
        spec("sizes", n_test, P.END_FRACTIONS, P.TEST_X, P.TEST_Z, 104),
        spec("poses", (n_test + 1) // 2, P.TEST_FRACTIONS, P.OUTER, P.OUTER_Z, 106,
             extra=(P.SetSpec("rotated", max(1, n_test // 2), P.TEST_FRACTIONS, (0.0,), (0.0,),
                              P.ROTATIONS_DEG),)),
        spec("turned", n_test, P.TEST_FRACTIONS, P.TEST_X, P.TEST_Z, 107,
             rotation_deg=TURNED_DEG),
        spec("shift-up", max(1, n_test // 2), P.TEST_FRACTIONS, P.TEST_X, P.TEST_Z, 108,
             P.shifted(bullet, P.SHIFT_HEADLINE)),
        spec("shift-down", max(1, n_test // 2), P.TEST_FRACTIONS, P.TEST_X, P.TEST_Z, 108,
             P.shifted(bullet, -P.SHIFT_HEADLINE)),
        spec("equal-split", n_test, P.TEST_FRACTIONS, P.TEST_X, P.TEST_Z, 102,
             replace(bullet, coupling="equal-torque")),
        spec("mujoco-test", n_test, P.TEST_FRACTIONS, P.TEST_X, P.TEST_Z, 102, mujoco),
    ])  # fmt: skip
    for engine, base in (("bullet", bullet), ("mujoco", mujoco)):
        train = out[f"{engine}-train"]
        table = Randomization.from_dict(randomized_table(engine), base=base)
        out[f"{engine}-train-randomized"] = replace(
            train, name=P.randomized_name(train.name), randomize=table
        )
        out[f"{engine}-posed-randomized"] = replace(
            train, name=f"{tag}{engine}-posed-randomized", offset_x=POSED_X, offset_z=POSED_Z,
            rotation_deg=TURNED_DEG, randomize=table, seed=103,
        )
    del out["mujoco-train"]  # only its randomised twins are training sets
    for k, hand in enumerate(OTHER_HANDS):
        if hand in hands:
            ctl = replace(mujoco, hand_model=str(Path(hands[hand]).resolve()))
            out[hand] = P.SetSpec(f"{tag}{hand}", n_test, OTHER_HAND_FRACTIONS, OTHER_HAND_X,
                                  OTHER_HAND_Z, controller=ctl, seed=141 + k)  # fmt: skip
    if objects is not None:
        poses = {"offset_x": {"min": -0.008, "max": 0.008},
                 "offset_z": {"min": -0.005, "max": 0.005},
                 "rotation_deg": {"min": 0.0, "max": 25.0}}  # fmt: skip
        out["household"] = SweepSet(f"{tag}household", _object_table(
            "household", FAMILY_OBJECTS, poses, n_object, objects), 151, str(objects))
        oof = _object_table("out-of-family", NO_FAMILY_OBJECTS, poses, n_object, objects)
        oof["shapes"] = [{"name": s, "offset_x": poses["offset_x"],
                          "offset_z": poses["offset_z"]}
                         for s in (*OUT_OF_FAMILY_SHAPES, *plugin_shapes)]  # fmt: skip
        out[OUT_OF_FAMILY] = SweepSet(f"{tag}{OUT_OF_FAMILY}", oof, 152, str(objects))
        table = {"name": OUT_OF_FAMILY_VALIDATION, "mode": "random", "samples": n_object,
                 "objects": [{"file": f"{o}.stl", "unit": "m", **poses}
                             for o in VALIDATION_OBJECTS]}  # fmt: skip
        out[OUT_OF_FAMILY_VALIDATION] = SweepSet(f"{tag}{OUT_OF_FAMILY_VALIDATION}", table, 153,
                                                 str(objects))  # fmt: skip
    return out


def _object_table(name: str, objects, poses: Mapping, samples: int, folder: Path) -> dict:
    from ..objects.examples import OBJECTS

    return {"name": name, "mode": "random", "samples": samples, "objects": [
        {"file": f"{o}.{OBJECTS[o][1]}", "unit": OBJECTS[o][2], **poses} for o in objects]}


def write_objects(folder: Path) -> Path:
    """The meshes the household and out-of-family sets grasp, written once."""
    from ..files import atomic_path
    from ..objects.examples import OBJECTS, write_object

    folder.mkdir(parents=True, exist_ok=True)
    for name in (*FAMILY_OBJECTS, *NO_FAMILY_OBJECTS):
        if not (folder / f"{name}.{OBJECTS[name][1]}").is_file():
            write_object(name, folder)
    for name, build in VALIDATION_OBJECTS.items():
        path = folder / f"{name}.stl"
        if not path.is_file():
            with atomic_path(path, "validation object") as tmp:
                build().export(tmp, file_type="stl")
    return folder


def _rounded_box(extents, radius: float):
    import trimesh

    half = np.asarray(extents, float) / 2 - radius
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    ball = trimesh.creation.icosphere(subdivisions=2, radius=radius)
    points = np.vstack([ball.vertices + c * half for c in corners])
    return trimesh.convex.convex_hull(points)


def _prism(section: np.ndarray, length: float):
    """A prism of a convex cross-section (k, 2), ``length`` along z, centred."""
    import trimesh

    ends = [np.c_[section, np.full(len(section), z)] for z in (-length / 2, length / 2)]
    return trimesh.convex.convex_hull(np.vstack(ends))


def _stadium(radius: float, flat: float, length: float):
    t = np.linspace(-np.pi / 2, np.pi / 2, 24)
    right = np.c_[flat / 2 + radius * np.cos(t), radius * np.sin(t)]
    return _prism(np.vstack([right, -right]), length)


def _spindle(radius: float, length: float):
    import trimesh

    profile = np.array([[0.0, -length / 2], [radius, 0.0], [0.0, length / 2]])
    return trimesh.creation.revolve(profile, sections=64)


def _ellipsoid(extents):
    import trimesh

    mesh = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    mesh.apply_scale(np.asarray(extents, float) / 2)
    return mesh


def _box(extents):
    import trimesh

    return trimesh.creation.box(extents=extents)


VALIDATION_OBJECTS: dict[str, Callable[[], Any]] = {
    "cuboid": lambda: _box((0.05, 0.07, 0.11)),
    "square_bar": lambda: _box((0.04, 0.04, 0.12)),
    "cube": lambda: _box((0.06, 0.06, 0.06)),
    "meat_tin": lambda: _rounded_box((0.1, 0.055, 0.085), 0.008),
    "triangular_prism": lambda: _prism(0.07 / math.sqrt(3) * np.array(
        [[math.cos(a), math.sin(a)] for a in (math.pi / 2, 7 * math.pi / 6, 11 * math.pi / 6)]),
        0.11),
    "spindle": lambda: _spindle(0.045, 0.13),
    "flat_ellipsoid": lambda: _ellipsoid((0.08, 0.05, 0.12)),
    "stadium_prism": lambda: _stadium(0.03, 0.03, 0.11),
}
"""The second out-of-family set (metres, main axis along z), declared before it was scored."""
OUT_OF_FAMILY_VALIDATION = "out-of-family-validation"
OUT_OF_FAMILY_SETS = (OUT_OF_FAMILY, OUT_OF_FAMILY_VALIDATION)


def plugin_shapes() -> list[str]:
    """Shapes registered by plugins that are no thesis family (the example plugin's capsule)."""
    from ..objects.shapes import BUILTIN_SHAPES
    from ..plugins import shape_names

    builtin = {s.name for s in BUILTIN_SHAPES}
    return [s for s in shape_names() if s not in builtin and s not in SHAPES]


def parse_hands(items: Sequence[str] | None) -> dict[str, str]:
    """``["menagerie=FILE", ...]`` -> {hand: path}; a UsageError for an unknown hand or a
    file that is not there (checked before any grasp)."""
    out: dict[str, str] = {}
    for item in items or ():
        for part in str(item).split(","):
            name, sep, path = part.partition("=")
            name = name.strip()
            if not sep or name not in OTHER_HANDS or not path.strip():
                raise UsageError(f"--other-hand takes NAME=FILE with NAME one of "
                                 f"{', '.join(OTHER_HANDS)}, got {part!r}")  # fmt: skip
            if name in out:
                raise UsageError(f"--other-hand names {name} twice")
            from ..sim.engines.mujoco_hand import load_hand_spec

            try:  # a bad model stops here, before any grasp
                load_hand_spec(path.strip())
            except UsageError as exc:  # its message names the option the file came by
                text = str(exc).replace("--hand-model ", f"--other-hand {name}=", 1)
                raise UsageError(text) from None
            out[name] = path.strip()
    return out


# --- reading a column ---------------------------------------------------------------------------


def _labels(records: Sequence[GraspRecord]) -> np.ndarray:
    return np.array([FAMILY_OBJECTS.get(r.shape, r.shape) for r in records]).astype(str)


def read_column(column: Column, sets: Mapping[str, list[GraspRecord]], seed: int):
    """The column's test records, read as the column says."""
    from ..learn.perturb import perturb_all

    records = [r for name in column.sets for r in sets[name]]
    if column.read == "noise":
        return perturb_all(records, NOISE, seed)
    if column.read in ("csv", "j0-only"):
        return replayed(records, coupled=column.read == "j0-only")
    return records


def replayed(records: Sequence[GraspRecord], coupled: bool = False) -> list[GraspRecord]:
    """``records`` exported as a Shadow hand's CSV (J0 only where ``coupled``) and imported
    back, as a user does with a real hand's recording: no contacts, no sizes, the shape from
    the label column."""
    from ..realhand.export import export
    from ..realhand.recordings import read_recording

    if not records:
        return []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "replay.csv"
        export(records, path, "csv", coupled=coupled)
        grasps = read_recording(path)
    if len(grasps) != len(records):
        raise RuntimeError(f"replay found {len(grasps)} grasps of {len(records)}")
    return [g.record for g in grasps]
