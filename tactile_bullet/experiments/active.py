"""The ``active`` protocol: accuracy after 1, 2 and 3 grasps of one object, with the next pose
planned (:mod:`.exploration`), drawn at random among the reachable moves, or the first pose
repeated; and, with the stopping rule (grasp again only while the fused answer is ambiguous
or unknown), the accuracy reached and the grasps used.

Its columns are the hard cases of issue 28, each on MuJoCo (a decision is simulated there):
objects near two families' border (a torus whose tube nearly closes the hole, a hyperboloid
with a slight waist, a short wide cylinder turned 20 deg), the five shapes at unseen poses
(offsets to +-10 mm, turned 10-25 deg), the household meshes a person calls a family (a can,
a ball, a vase, a paper cup; turned 0-25 deg, as the robustness matrix's household column),
and, where ``--other-hand`` names their models, the hands written by others. Every strategy
grasps the same objects at the same first pose; each sequence runs to three grasps, and the
fused answer after each is scored against the object's family. The ``out-of-family`` column
(the household meshes of no family and the thesis' modified shapes) is scored the other way:
an answer there is right where it is ``unknown``.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import UsageError
from ..records import ControllerSettings, Pose

STRATEGIES = ("planned", "planned+simulated", "random", "repeat")
"""How the next pose is chosen (and, for ``planned+simulated``, the later grasps read by the
simulated hypotheses instead of the model's own answers: exploration.simulated_likelihoods)."""
SCALES = {"full": 8, "quick": 3, "tiny": 1}
"""Objects per family and column, by scale."""
GRASPS = 3
OUT_OF_FAMILY = "out-of-family"
"""The column of objects of no family, right where the fused answer is ``unknown``."""


def border_objects(n: int, rng: np.random.Generator) -> list[tuple[str, dict, Pose]]:
    """Objects near two families' border, each at a first pose near the centre."""
    out = []
    for _ in range(n):
        minor = float(rng.uniform(0.050, 0.055))
        out.append(("torus", {"major_radius": float(rng.uniform(minor + 0.002, minor + 0.006)),
                              "minor_radius": minor}, _centre(rng)))  # fmt: skip
        waist = float(rng.uniform(0.032, 0.040))
        out.append(("hyperboloid", {"waist_radius": waist,
                                    "end_radius": waist + float(rng.uniform(0.004, 0.008))},
                    _centre(rng)))  # fmt: skip
        out.append(("cylinder", {"radius": float(rng.uniform(0.045, 0.055)),
                                 "length": float(rng.uniform(0.10, 0.12))},
                    replace(_centre(rng), rotation=math.radians(20.0))))  # fmt: skip
    return out


def _centre(rng: np.random.Generator) -> Pose:
    return Pose((float(rng.uniform(-0.003, 0.003)), 0.0, float(rng.uniform(-0.002, 0.002))))


def posed_objects(n: int, rng: np.random.Generator) -> list[tuple[str, dict, Pose]]:
    """The five shapes at middle sizes, at poses the default never trained on."""
    from ..objects.shapes import BUILTIN_SHAPES

    table = {s.name: s for s in BUILTIN_SHAPES}
    out = []
    for _ in range(n):
        for shape in ("cone", "torus", "sphere", "hyperboloid", "cylinder"):
            spec = table[shape]
            frac = float(rng.uniform(0.25, 0.75))
            params = {k: p.min + frac * (p.max - p.min) for k, p in spec.params.items()}
            x = float(rng.choice([-0.010, 0.010]))
            deg = float(rng.uniform(10.0, 25.0)) * float(rng.choice([-1, 1]))
            out.append((shape, params, Pose((x, 0.0, float(rng.uniform(-0.005, 0.005))),
                                            math.radians(deg))))  # fmt: skip
    return out


def household_objects(n: int, rng: np.random.Generator,
                      folder: Path) -> list[tuple[Any, dict, Pose, str]]:  # fmt: skip
    """The household meshes a person calls a family (``robustness_sets.FAMILY_OBJECTS``),
    written to ``folder`` once, each grasped ``n`` times a few mm off centre and turned 0-25
    deg: (mesh shape, {}, first pose, family)."""
    from ..objects.examples import OBJECTS, write_object
    from ..objects.meshes import load_mesh
    from .robustness_sets import FAMILY_OBJECTS

    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for _ in range(n):
        for name, family in FAMILY_OBJECTS.items():
            _, ext, unit, _ = OBJECTS[name]
            path = folder / f"{name}.{ext}"
            if not path.is_file():
                write_object(name, folder)
            pose = Pose((float(rng.uniform(-0.008, 0.008)), 0.0, float(rng.uniform(-0.005, 0.005))),
                        math.radians(float(rng.uniform(0.0, 25.0))))  # fmt: skip
            out.append((load_mesh(path, unit), {}, pose, family))
    return out


def no_family_objects(n: int, rng: np.random.Generator,
                      folder: Path) -> list[tuple[Any, dict, Pose, None]]:  # fmt: skip
    """Objects of no family, each grasped ``n`` times at a first pose as the household
    meshes' (a few mm off centre, turned 0-25 deg): the robustness matrix's out-of-family
    meshes (``robustness_sets.NO_FAMILY_OBJECTS``, written to ``folder`` once) and the
    thesis' modified shapes at middle sizes: (shape, sizes, first pose, None: no family is
    right)."""
    from ..objects.examples import OBJECTS, write_object
    from ..objects.meshes import load_mesh
    from ..objects.shapes import BUILTIN_SHAPES
    from .robustness_sets import NO_FAMILY_OBJECTS, OUT_OF_FAMILY_SHAPES

    folder.mkdir(parents=True, exist_ok=True)
    table = {s.name: s for s in BUILTIN_SHAPES}
    out: list[tuple[Any, dict, Pose, None]] = []
    for _ in range(n):
        for name in (*NO_FAMILY_OBJECTS, *OUT_OF_FAMILY_SHAPES):
            pose = Pose((float(rng.uniform(-0.008, 0.008)), 0.0, float(rng.uniform(-0.005, 0.005))),
                        math.radians(float(rng.uniform(0.0, 25.0))))  # fmt: skip
            if name in table:
                mid = {k: 0.5 * (p.min + p.max) for k, p in table[name].params.items()}
                out.append((name, mid, pose, None))
                continue
            _, ext, unit, _ = OBJECTS[name]
            path = folder / f"{name}.{ext}"
            if not path.is_file():
                write_object(name, folder)
            out.append((load_mesh(path, unit), {}, pose, None))
    return out


def is_right(fused: Mapping[str, Any], truth: str | None) -> bool:
    """Whether a fused answer is right: it names the object's family, or, for an object of no
    family (``truth`` None), it is ``unknown``."""
    return bool(fused["unknown"]) if truth is None else fused["shape"] == truth


def columns(scale: str, hands: Mapping[str, str], seed: int = 0,
            objects: Path | None = None) -> dict[str, tuple]:  # fmt: skip
    """Column -> (controller, objects), each object (shape, sizes, first pose[, family: the
    answer that is right, where the shape is a mesh]). ``objects``: the folder the household
    meshes are written to (no household column without it)."""
    from ..datasets.sweeps import geometry_ok

    n = SCALES[scale]
    rng = np.random.default_rng(seed)
    mujoco = ControllerSettings(engine="mujoco")
    out = {
        "border": (mujoco, border_objects(n, rng)),
        "unseen-poses": (mujoco, posed_objects(n, rng)),
    }
    out = {k: (c, [o for o in objs if geometry_ok(o[0], o[1])]) for k, (c, objs) in out.items()}
    if objects is not None:
        out["household"] = (mujoco, household_objects(n, np.random.default_rng(seed + 2),
                                                      objects))  # fmt: skip
        out[OUT_OF_FAMILY] = (mujoco, no_family_objects(n, np.random.default_rng(seed + 3),
                                                         objects))  # fmt: skip
    for name, path in sorted(hands.items()):
        ctl = replace(mujoco, hand_model=str(Path(path).resolve()))
        out[name] = (ctl, [o for o in posed_objects(n, np.random.default_rng(seed + 1))
                           if geometry_ok(o[0], o[1])])  # fmt: skip
    return out


def run_active(
    out: str | os.PathLike,
    scale: str = "quick",
    hands: Mapping[str, str] | None = None,
    seed: int = 0,
    log: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run every strategy on every column's objects; write ``active.json`` and ``table.md``."""
    from ..learn.default import default_model
    from .reports import write_json, write_text_atomic

    if scale not in SCALES:
        raise UsageError(f"unknown scale {scale!r} (known: {', '.join(SCALES)})")
    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise UsageError(f"--out {out} is not empty: choose another")
    out.mkdir(parents=True, exist_ok=True)
    say = log or (lambda _m: None)
    model = default_model()
    started = time.perf_counter()
    rows = []
    decisions = []
    for column, (controller, objects) in columns(scale, hands or {}, seed,
                                                 out / "objects").items():  # fmt: skip
        for strategy in STRATEGIES:
            row, seconds = score_column(objects, controller, model, strategy, seed)
            row = {"column": column, **row}
            decisions += seconds
            rows.append(row)
            say(f"{column} {strategy}: after 1/2/3 grasps "
                + "/".join(f"{100 * v:.0f}" for v in row["after"])
                + f"%, with stopping {100 * row['with_stopping']:.0f}% in "
                f"{row['mean_grasps']:.2f} grasps")  # fmt: skip
    doc = {"config": {"scale": scale, "seed": seed, "hands": dict(hands or {})}, "rows": rows,
           "decision_s": {"median": float(np.median(decisions)) if decisions else None,
                          "max": float(np.max(decisions)) if decisions else None,
                          "decisions": len(decisions)},
           "wall_time_s": time.perf_counter() - started}  # fmt: skip
    write_json(out / "active.json", doc)
    write_text_atomic(out / "table.md", table_text(rows))
    return doc


def score_column(objects: Sequence[tuple], controller: ControllerSettings, model,
                 strategy: str, seed: int) -> tuple[dict[str, Any], list[float]]:
    """One strategy (``planned``, ``random``, ``repeat``, each optionally ``+simulated``) on one
    column's objects, each explored to ``GRASPS`` grasps: its row (``strategy``, ``objects``,
    ``after``: the share right after 1..GRASPS grasps, ``with_stopping``, ``mean_grasps``,
    ``right``: per object, right after each count (:func:`is_right`); ``shapes`` and
    ``unknown``: per object, the fused answer's shape after each count and whether it is
    unknown, and ``stop_unknown`` with the stopping rule; ``made``: per object, its true
    family (None: of no family) and each grasp's pose and own answer) and each planning
    decision's seconds."""
    from .exploration import SimulationCache, explore, settled

    after = np.zeros((len(objects), GRASPS), bool)
    unknown = np.zeros((len(objects), GRASPS), bool)
    shapes: list[list[str]] = []
    stop_right, stop_unknown, stop_used, seconds, made = [], [], [], [], []
    how, _, fusion = strategy.partition("+")
    for i, (shape, params, first, *family) in enumerate(objects):
        truth = family[0] if family else shape
        doc = explore(shape, params, first, controller, max_grasps=GRASPS, model=model,
                      strategy=how, seed=seed + i, cache=SimulationCache(),
                      until_settled=False, fusion=fusion or "model")  # fmt: skip
        seconds += [d["seconds"] for d in doc["decisions"]]
        fused = doc["fused"]
        counts = [fused[min(k, len(fused) - 1)] for k in range(GRASPS)]  # the last repeated
        after[i] = [is_right(f, truth) for f in counts]
        unknown[i] = [bool(f["unknown"]) for f in counts]
        shapes.append([str(f["shape"]) for f in counts])
        stop = next((k for k, f in enumerate(fused) if settled(f)), len(fused) - 1)
        # where explore's own loop stops: a planned pose already grasped (``repeats``)
        stop = min([stop, *(k for k, d in enumerate(doc["decisions"]) if d["repeats"])])
        stop_right.append(is_right(fused[stop], truth))
        stop_unknown.append(bool(fused[stop]["unknown"]))
        stop_used.append(stop + 1)
        made.append({"truth": truth, "grasps": [_grasp_doc(g) for g in doc["grasps"]]})
    row = {"strategy": strategy, "objects": len(objects),
           "after": [float(v) for v in after.mean(axis=0)],
           "with_stopping": float(np.mean(stop_right)),
           "mean_grasps": float(np.mean(stop_used))}  # fmt: skip
    return row | {"right": after.tolist(), "stop_right": stop_right,
                  "shapes": shapes, "unknown": unknown.tolist(), "stop_unknown": stop_unknown,
                  "made": made}, seconds  # fmt: skip


def _grasp_doc(entry: Mapping[str, Any]) -> dict[str, Any]:
    """What a row keeps of one grasp: its pose and its own answer (shape, probabilities,
    unknown and why, ambiguous, renamed_from), so that another fusion of the same grasps can
    be scored offline (``benchmarks/active_fusion.py``) without simulating them again."""
    answer = entry["answer"]
    keep = ("shape", "probabilities", "unknown", "unknown_why", "ambiguous", "renamed_from")
    return {"pose": entry["pose"], **{k: answer.get(k) for k in keep}}


def table_text(rows: Sequence[Mapping[str, Any]]) -> str:
    head = ["column", "next pose", "objects", "1 grasp", "2 grasps", "3 grasps",
            "with stopping", "grasps used"]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        lines.append("| " + " | ".join([r["column"], r["strategy"], str(r["objects"]),
                                          *(f"{100 * v:.1f}" for v in r["after"]),
                                          f"{100 * r['with_stopping']:.1f}",
                                          f"{r['mean_grasps']:.2f}"]) + " |")  # fmt: skip
    return "\n".join(lines) + "\n"
