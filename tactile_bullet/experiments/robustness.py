"""The robustness matrix: every candidate method on every test condition, scored by its worst.

docs/robustness.md declares the rule (written before the first run): a method (descriptor,
classifier, training) scores its lowest accuracy over the accuracy columns, leaving out the
columns it was chosen on (:data:`SEEN`); the eligible method with the highest score is the
default identifier. This module holds the columns, the candidates and the scoring; the sets
are simulated through the dataset layer (sharded, resumable, cached under ``--cache``), as the
benchmark's are.

Each column is a test set of the five thesis shapes made by one hand, read one way:

- our hand in Bullet: ``sizes`` (range ends), ``poses`` (outer offsets and rotations),
  ``turned`` (0-25 deg), ``noise`` (1 deg joint noise + 3 deg calibration bias), ``shift``
  (every physics knob +-20%), ``equal-split`` (J1 and J2 sharing the bend), ``j0-only`` (the
  held-out grasps exported as a hand that publishes J0 only and imported back);
- ``mujoco``: our MJCF hand in MuJoCo;
- ``menagerie``, ``gymnasium``: Shadow hands written by others (``--other-hand NAME=FILE``,
  a model ``convert-hand`` wrote), in MuJoCo, exported as a hand's CSV and imported back (no
  contacts, as a real hand reports);
- ``household``: the example meshes a person would call one of the families.

The ``out-of-family`` set (the ovoid, the hexagonal pyramid, every shape a plugin adds that is
no thesis family, the no-family household meshes) is scored by the share answered unknown.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
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
    "none": ("bullet-train",),
}
"""Training name -> the sets it joins (``none``: the training-free shape fit, which is fitted
on the Bullet set only to learn its class names)."""
RANDOMIZED = ("bullet-randomized", "mujoco-randomized", "both-randomized", "posed-randomized")
LEARNT = ("bullet", *RANDOMIZED)


@dataclass(frozen=True)
class Candidate:
    """A descriptor (with parameters) and a classifier, with the trainings it is tried on."""

    descriptor: str
    classifier: str
    trainings: tuple[str, ...] = LEARNT
    params: tuple[tuple[str, Any], ...] = ()
    plugin: bool = False
    """Needs a plugin package (shown, never the default)."""

    @property
    def label(self) -> str:
        extra = ",".join(f"{k}={json.dumps(v)}" for k, v in self.params)
        return f"{self.descriptor}{'@' + extra if extra else ''} + {self.classifier}"


_PAIRS = ("signature", "coupled-signature", "raw-joints", "coupled-joints", "robust-joints",
          "finger-points", "coupled-finger-points", "signature+coupled-joints")  # fmt: skip
CANDIDATES: tuple[Candidate, ...] = (
    *(Candidate(d, c) for d in _PAIRS for c in ("svm", "knn")),
    *(Candidate("finger-points", c, params=(("profile", True),)) for c in ("svm", "knn")),
    Candidate("robust-joints", "shape-fit", ("none",)),
    Candidate("contact-normals", "svm"),
    Candidate("time-series", "random-forest", plugin=True),
    Candidate("coupled-time-series", "random-forest", plugin=True),
)
"""Every method the matrix scores (docs/robustness.md, rule 7)."""

POSED_X = (-0.010, -0.005, 0.0, 0.005, 0.010)
POSED_Z = (-0.010, -0.005, 0.0, 0.005, 0.010)
"""Offsets (m) of the posed training recipe (added after the first full run, docs/robustness.md);
its rotations are :data:`TURNED_DEG`."""

SEEN: dict[str, tuple[str, ...]] = {
    "finger-points": ("menagerie", "gymnasium"),
    "coupled-finger-points": ("menagerie", "gymnasium"),
    "mujoco-randomized": ("gymnasium",),
    "both-randomized": ("gymnasium",),
    "posed-randomized": ("gymnasium", "poses", "turned", "household"),
}
"""Descriptor or training -> columns it was chosen after seeing (rule 2): marked ``*`` and
left out of its score."""


def select_candidates(descriptors: str | None, classifiers: str | None) -> list[Candidate]:
    """The candidates whose descriptor and classifier are among the comma lists given (all
    where None); a UsageError where none is left."""
    def names(text):
        return None if not text else {n.strip() for n in text.split(",") if n.strip()}

    descs, clfs = names(descriptors), names(classifiers)
    chosen = [c for c in CANDIDATES if (descs is None or c.descriptor in descs)
              and (clfs is None or c.classifier in clfs)]  # fmt: skip
    if not chosen:
        raise UsageError("no candidate method of docs/robustness.md matches --descriptor "
                         "and --classifier")  # fmt: skip
    return chosen


def seen_columns(candidate: Candidate, training: str) -> set[str]:
    """The columns that do not count toward this method's score."""
    return set(SEEN.get(candidate.descriptor, ())) | set(SEEN.get(training, ()))


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
    scale: str, hands: Mapping[str, str], objects: Path | None, plugin_shapes: Sequence[str] = ()
) -> dict[str, Any]:
    """Every set the matrix reads, by short name (columns and trainings name them so): each a
    :class:`protocols.SetSpec` or a :class:`SweepSet` whose ``name`` is its cache folder."""
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

            load_hand_spec(path.strip())  # a bad model stops here, before any grasp
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


# --- scoring -------------------------------------------------------------------------------------


@dataclass
class _Fitted:
    estimator: Any
    calibration: dict[str, Any]
    novelty: Any


def _shape_fit_names(records, cache: dict[int, str], classes) -> np.ndarray:
    """The shape fit's answer for each record, each read once per run (keyed by identity)."""
    from ..learn.doubt import cross_check_names

    todo = [r for r in records if id(r) not in cache]
    for r, name in zip(todo, cross_check_names(todo, classes), strict=True):
        cache[id(r)] = name
    return np.array([cache[id(r)] for r in records], dtype=object).astype(str)


def score_matrix(
    sets: Mapping[str, list[GraspRecord]],
    candidates: Sequence[Candidate],
    seed: int = 0,
    show: bool = False,
    log: Callable[[str], None] | None = None,
) -> list[dict[str, Any]]:
    """One row per candidate and training: accuracy, doubt and unknown share per column (None
    with a ``reason`` where the method cannot run there), its score and its eligibility."""
    from ..learn.doubt import calibrate_margin, cross_flags, flagged, margins
    from ..learn.novelty import Novelty
    from ..plugins import compatible, get_classifier, get_descriptor

    say = log or (lambda _m: None)
    columns = [c for c in COLUMNS if all(s in sets for s in c.sets)]
    tests = {c.name: read_column(c, sets, seed) for c in columns}
    oof = {n: sets[n] for n in OUT_OF_FAMILY_SETS if n in sets}
    fit_cache: dict[int, str] = {}
    rows = []
    runs = [(c, t) for c in candidates for t in c.trainings]
    for i, (cand, training) in enumerate(runs, 1):
        started = time.perf_counter()
        row: dict[str, Any] = {"method": cand.label, "descriptor": cand.descriptor,
                               "params": dict(cand.params), "classifier": cand.classifier,
                               "training": training, "plugin": cand.plugin, "columns": {},
                               "seen": sorted(seen_columns(cand, training))}  # fmt: skip
        if not compatible(cand.descriptor, cand.classifier):
            continue
        desc = get_descriptor(cand.descriptor, **dict(cand.params))
        train = [r for s in TRAININGS[training] for r in sets[s]]
        y = _labels(train)
        x = np.asarray(desc.transform(train), float)
        fitted = _fit(cand, x, y, train, seed, fit_cache, calibrate_margin, get_classifier,
                      Novelty)  # fmt: skip
        classes = [str(c) for c in fitted.estimator.classes_]
        for col, name in [*((c, c.name) for c in columns), *((None, n) for n in oof)]:
            records = tests[name] if col else oof[name]
            reason = _cannot_read(cand, records)
            if reason:
                row["columns"][name] = {"accuracy": None, "reason": reason}
                continue
            xt = np.asarray(desc.transform(records), float)
            pred = np.asarray(fitted.estimator.predict(xt)).astype(str)
            proba = np.asarray(fitted.estimator.predict_proba(xt), float)
            m = margins(proba, np.array([classes.index(p) for p in pred]))[0]
            flags = flagged(m, fitted.calibration.get("margin"))
            if fitted.calibration.get("cross_check") is not None:
                flags |= cross_flags(pred, _shape_fit_names(records, fit_cache, classes))
            unknown = fitted.novelty.unknown(xt) if fitted.novelty is not None else \
                np.zeros(len(xt), bool)  # fmt: skip
            truth = _labels(records)
            right = pred == truth
            doubt = flags | unknown
            cell = {"n": int(len(records)), "unknown": float(np.mean(unknown))}
            if col is not None:
                cell |= {
                    "accuracy": float(np.mean(right)),
                    "wrong_flagged": float(np.mean(doubt[~right])) if (~right).any() else None,
                    "right_flagged": float(np.mean(doubt[right])) if right.any() else None,
                }  # fmt: skip
            row["columns"][name] = cell
        _summarise(row)
        rows.append(row)
        say(f"[{i}/{len(runs)}] {cand.label} ({training}): worst {_pct(row['score'])} "
            f"({time.perf_counter() - started:.0f} s)")  # fmt: skip
    return rows


def _fit(cand, x, y, train, seed, fit_cache, calibrate_margin, get_classifier, Novelty):
    estimator = get_classifier(cand.classifier).fit(x, y)
    if cand.classifier == "shape-fit":
        calibration: dict[str, Any] = {"margin": None, "cross_check": None}
    else:
        calibration = calibrate_margin(lambda: get_classifier(cand.classifier), x, y,
                                       seed=seed, records=train, classifier=cand.classifier,
                                       names=lambda recs, cls: _shape_fit_names(
                                           recs, fit_cache, cls))  # fmt: skip
    try:
        novelty = Novelty.fit(x, y, seed=seed)
    except ValueError:
        novelty = None
    return _Fitted(estimator, calibration, novelty)


def _cannot_read(cand: Candidate, records: Sequence[GraspRecord]) -> str | None:
    if not records:
        return "no grasps"
    if "contact" in cand.descriptor and all(r.source == "recorded" for r in records):
        return "no contacts in a hand's CSV"
    return None


def _summarise(row: dict[str, Any]) -> None:
    """The row's score (worst counted column), mean, and eligibility (rules 1-3)."""
    cells = {k: v for k, v in row["columns"].items() if k not in OUT_OF_FAMILY_SETS}
    counted = {k: v["accuracy"] for k, v in cells.items() if k not in row["seen"]}
    missing = sorted(k for k, v in counted.items() if v is None)
    values = [v for v in counted.values() if v is not None]
    row["score"] = min(values) if values and not missing else None
    row["mean"] = float(np.mean(values)) if values else None
    reasons = []
    if row["plugin"]:
        reasons.append("needs a plugin")
    if missing:
        reasons.append(f"n/a on {', '.join(missing)}")
    row["eligible"] = not reasons
    row["not_eligible"] = "; ".join(reasons) or None


def winner(rows: Sequence[Mapping[str, Any]]) -> Mapping[str, Any] | None:
    """The default by the declared rule: highest worst column, ties (within one grasp of the
    smallest column) to the higher mean."""
    eligible = [r for r in rows if r["eligible"] and r["score"] is not None]
    if not eligible:
        return None
    best = max(r["score"] for r in eligible)
    tie = min(min(c["n"] for c in r["columns"].values() if c.get("n")) for r in eligible)
    close = [r for r in eligible if r["score"] >= best - 1.0 / max(1, tie) + 1e-12]
    return max(close, key=lambda r: (r["mean"] or 0.0))


def _pct(value: float | None) -> str:
    return "n/a" if value is None else f"{100 * value:.1f}"


def table_text(rows: Sequence[Mapping[str, Any]], chosen: Mapping[str, Any] | None) -> str:
    """The matrix as a Markdown table, best score first; ``*`` marks a column the method was
    chosen on (not counted), ``n/a`` one it cannot read."""
    names = [c for c in COLUMN_NAMES if any(c in r["columns"] for r in rows)]
    head = ["method", "training", *names, "worst", "mean", "unknown: out of family",
            "validation"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    order = sorted(rows, key=lambda r: (r["score"] is None, -(r["score"] or 0), -(r["mean"] or 0)))
    for r in order:
        cells = []
        for c in names:
            cell = r["columns"].get(c)
            if cell is None:
                cells.append("")
                continue
            text = _pct(cell.get("accuracy"))
            cells.append(text + ("*" if c in r["seen"] else ""))
        oof = [r["columns"].get(n) for n in OUT_OF_FAMILY_SETS]
        name = r["method"] + (" (plugin)" if r["plugin"] else "")
        if chosen is not None and r is chosen:
            name = f"**{name}** (default)"
        lines.append("| " + " | ".join([name, r["training"], *cells, _pct(r["score"]),
                                          _pct(r["mean"]),
                                          *(_pct(o["unknown"]) if o else "" for o in oof)])
                     + " |")  # fmt: skip
    return "\n".join(lines) + "\n"


def run_robustness(
    out: str | os.PathLike,
    *,
    scale: str = "full",
    workers: int = 2,
    seed: int = 0,
    cache: str | os.PathLike | None = None,
    hands: Mapping[str, str] | None = None,
    candidates: Sequence[Candidate] | None = None,
    show: bool = False,
    log: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Simulate every set (cached, resumable), score every candidate, write ``robustness.json``
    and ``table.md`` under ``out``, and return the document."""
    from .benchmark import load_set, prepare_out, simulate_sets
    from .reports import write_json, write_text_atomic

    if scale not in SCALES:
        raise UsageError(f"unknown scale {scale!r} (known: {', '.join(SCALES)})")
    say = log or (lambda _m: None)
    started = time.perf_counter()
    hands = dict(hands or {})
    out = Path(out)
    cache_dir = Path(cache) if cache is not None else out / "data"
    chosen = _available(candidates or CANDIDATES)
    config = {"protocols": ["robustness"], "scale": scale, "seed": int(seed),
              "hands": {k: str(Path(v).resolve()) for k, v in sorted(hands.items())},
              "methods": [c.label for c in chosen]}  # fmt: skip
    prepare_out(out, config)
    objects = write_objects(cache_dir / "objects")
    specs = set_specs(scale, hands, objects, plugin_shapes())
    simulate_sets(list(specs.values()), cache_dir, int(workers), show, say)
    sets: dict[str, list[GraspRecord]] = {}
    for short, spec in specs.items():
        sets[short], _missed = load_set(cache_dir / spec.name)
    simulated = time.perf_counter() - started
    rows = score_matrix(sets, chosen, seed=seed, show=show, log=say)
    best = winner(rows)
    missing = [c.name for c in COLUMNS if c.hand and c.hand not in hands]
    doc = {
        "config": config,
        "columns": {c.name: c.description for c in COLUMNS},
        "not_run": {c: f"no --other-hand {c}=FILE given" for c in missing},
        "rows": rows,
        "default": None if best is None else {k: best[k] for k in (
            "method", "descriptor", "params", "classifier", "training", "score", "mean")},
        "sets": {k: len(v) for k, v in sets.items()},
        "simulate_s": simulated,
        "wall_time_s": time.perf_counter() - started,
    }  # fmt: skip
    write_json(out / "robustness.json", doc)
    write_text_atomic(out / "table.md", table_text(rows, best))
    return doc


def _available(candidates: Sequence[Candidate]) -> list[Candidate]:
    """The candidates whose descriptor and classifier are installed (a plugin's may not be)."""
    from ..plugins import classifier_names, descriptor_names

    descs, clfs = set(descriptor_names()), set(classifier_names())
    return [c for c in candidates
            if all(p in descs for p in c.descriptor.split("+")) and c.classifier in clfs]


__all__ = ["CANDIDATES", "COLUMNS", "Candidate", "Column", "run_robustness", "score_matrix",
           "winner", "table_text", "set_specs", "replayed"]  # fmt: skip


def fit_model(
    descriptor: str, params: Mapping[str, Any], classifier: str,
    records: Sequence[GraspRecord], seed: int = 0, info: Mapping[str, Any] | None = None,
):  # fmt: skip
    """A saved-model-ready :class:`~tactile_bullet.learn.models.Model` of one method on
    ``records``: the classifier, its doubt (margin and the shape fit's second opinion,
    calibrated on held-out folds) and its novelty (unknown at most 5% of held-out in-family
    grasps); what ``tools/make_default_model.py`` ships."""
    from ..learn.doubt import model_doubt
    from ..learn.models import Model
    from ..learn.novelty import Novelty
    from ..plugins import get_classifier, get_descriptor

    desc = get_descriptor(descriptor, **dict(params))
    x = np.asarray(desc.transform(records), float)
    y = _labels(records)
    estimator = get_classifier(classifier).fit(x, y)
    doubt: dict[str, Any] = {"margin": None, "cross_check": None}
    if classifier != "shape-fit":
        doubt = model_doubt(lambda: get_classifier(classifier), x, y, records, classifier)
    novelty = Novelty.fit(x, y, seed=seed)
    return Model(descriptor, dict(params), classifier, {}, estimator,
                 info={**dict(info or {}), "doubt": doubt, "novelty": novelty.summary(),
                       "train_records": len(records)},
                 novelty=novelty)  # fmt: skip


def training_records(cache: Path, scale: str, training: str) -> list[GraspRecord]:
    """The records of one of the matrix's trainings, read from its cache."""
    from .benchmark import load_set

    specs = set_specs(scale, {}, None)
    return [r for short in TRAININGS[training] for r in load_set(cache / specs[short].name)[0]]
