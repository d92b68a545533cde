"""The user's workflow on top of the registry: train, evaluate, compare, identify, demo.

The whole path the CLI runs, importable from one place: fitting a method to records and using
it (``records_from``, ``split``, ``train``, ``predict``, ``evaluate``, ``identify``,
``compare``) lives in :mod:`~tactile_bullet.experiments.training` and is re-exported here; the
demo's protocol (test sizes and offsets never seen in training, simulated, trained, compared
and reported) is this module's own.

Every function takes and returns plain objects (records, models, JSON-ready dicts) so the CLI
is a thin layer over them and scripts can call them directly.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..console import plural
from ..datasets.bulk import GraspSpec, check_record_folder, save_records, simulate_many
from ..errors import UsageError
from ..records import ControllerSettings, GraspRecord, Pose
from .training import (
    LATENCY_SAMPLES,
    MIN_TRAIN_PER_SHAPE,
    compare,
    describe_model,
    evaluate,
    identify,
    labels_of,
    predict,
    records_from,
    split,
    train,
)

__all__ = [  # the training module's names, re-exported, then the demo's
    "LATENCY_SAMPLES", "MIN_TRAIN_PER_SHAPE", "compare", "describe_model", "evaluate", "identify",
    "labels_of", "predict", "records_from", "split", "train",
    "DEMO_CLASSIFIERS", "DEMO_REPORT_FILES", "DEMO_SHAPES", "TEST_FRACTIONS", "TEST_OFFSETS",
    "TRAIN_FRACTIONS", "TRAIN_OFFSETS", "SimulatedSet", "demo", "demo_text", "draw_specs",
    "simulate_set",
]  # fmt: skip

DEMO_SHAPES: tuple[str, ...] = ("cone", "torus", "sphere", "hyperboloid", "cylinder")
"""The thesis' five test shapes."""


def _demo_classifiers() -> tuple[str, ...]:
    """Classifiers the demo compares on the signature: the ones that train in seconds, with
    the neural forest where torch is installed (the ``torch`` extra)."""
    import importlib.util

    names = ("svm", "knn", "som", "dtw-template")
    return names + (("neural-forest",) if importlib.util.find_spec("torch") else ())


DEMO_CLASSIFIERS: tuple[str, ...] = _demo_classifiers()

TRAIN_FRACTIONS: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)
"""Relative sizes (in each parameter's valid range) the demo trains on."""
TEST_FRACTIONS: tuple[float, ...] = (0.125, 0.375, 0.625, 0.875)
"""Relative sizes it tests on: interleaved with the training ones, never equal to them."""
TRAIN_OFFSETS: tuple[tuple[float, float, float], ...] = (
    (-0.010, 0.0, -0.005), (0.0, 0.0, -0.005), (0.010, 0.0, -0.005),
    (-0.010, 0.0, 0.005), (0.0, 0.0, 0.005), (0.010, 0.0, 0.005),
)  # fmt: skip
"""Object offsets (m) seen in training: +-10 mm along O-O', +-5 mm along the fingers."""
TEST_OFFSETS: tuple[tuple[float, float, float], ...] = (
    (-0.005, 0.0, 0.0),
    (0.005, 0.0, 0.0),
    (0.0, 0.0, 0.0),
    (0.005, 0.0, 0.0025),
)
"""Offsets tested: between the training ones, none equal to any of them."""

DEMO_REPORT_FILES: tuple[str, ...] = ("signatures.png", "comparison.json", "demo.json")
"""What the demo writes into ``report/`` besides the evaluation report."""


def draw_specs(
    shape: str,
    n: int,
    fractions: Sequence[float],
    offsets: Sequence[tuple[float, float, float]],
    rng: np.random.Generator,
    controller: ControllerSettings | None = None,
) -> list[GraspSpec]:
    """``n`` grasps of a built-in shape, each parameter at a relative size drawn from
    ``fractions`` of its valid range, at an offset drawn from ``offsets``; combinations the
    shape refuses (a torus whose hole would close) are drawn again."""
    from ..objects.shapes import BUILTIN_SHAPES

    spec = next(s for s in BUILTIN_SHAPES if s.name == shape)
    out = []
    for _ in range(n):
        for _attempt in range(100):
            given = {
                k: p.min + float(rng.choice(fractions)) * (p.max - p.min)
                for k, p in spec.params.items()
            }
            try:
                values = spec.resolve(given)
                break
            except UsageError:
                continue
        else:  # pragma: no cover - every built-in shape has valid combinations
            raise UsageError(f"no valid size of {shape} among the demo's fractions")
        offset = offsets[int(rng.integers(len(offsets)))]
        out.append(GraspSpec(shape, values, Pose(offset), int(rng.integers(2**31 - 1)), controller))
    return out


@dataclass
class SimulatedSet:
    """Records of a demo set and what was lost on the way."""

    records: list[GraspRecord]
    refused: list[str]
    """Poses the simulator refused (the object would overlap the open hand)."""
    no_contact: int
    """Grasps that touched nothing: no shape information, left out."""


def simulate_set(
    per_shape: int,
    fractions: Sequence[float],
    offsets: Sequence[tuple[float, float, float]],
    rng: np.random.Generator,
    workers: int = 1,
    show: bool = False,
    desc: str = "grasps",
    shapes: Sequence[str] = DEMO_SHAPES,
    rounds: int = 3,
    controller: ControllerSettings | None = None,
) -> SimulatedSet:
    """``per_shape`` usable grasps of each shape where possible: a refused pose or a grasp
    without contact is replaced by a fresh draw, for up to ``rounds`` rounds, so every shape
    keeps its share of the set."""
    wanted = {name: per_shape for name in shapes}
    kept: dict[str, list[GraspRecord]] = {name: [] for name in shapes}
    refused: list[str] = []
    no_contact = 0
    for _ in range(rounds):
        specs = [
            s
            for name, n in wanted.items()
            for s in draw_specs(name, n, fractions, offsets, rng, controller)
        ]
        if not specs:
            break
        records, failures = simulate_many(specs, workers, show, desc)
        refused += failures
        for rec in records:
            if "no_contact" in rec.flags:
                no_contact += 1
                continue
            kept[rec.shape].append(rec)
        wanted = {name: per_shape - len(kept[name]) for name in shapes}
    return SimulatedSet([r for name in shapes for r in kept[name]], refused, no_contact)


def demo(
    out: str | os.PathLike = "tactile-bullet-demo",
    seed: int = 0,
    train_per_shape: int = 24,
    test_per_shape: int = 12,
    workers: int = 2,
    classifiers: Sequence[str] = DEMO_CLASSIFIERS,
    show: bool = False,
    log: Callable[[str], None] | None = None,
    force: bool = False,
    engine: str = "bullet",
) -> dict[str, Any]:
    """The first thing to run: simulate a training set and a held-out test set of the five
    thesis shapes (test sizes and offsets never seen in training), train signature + SVM,
    score it, compare the other cheap classifiers, and write a report folder.

    ``out`` receives ``train/`` and ``test/`` (the simulated records), ``model.npz`` (the
    signature + SVM model) and ``report/`` (report.json, confusion matrix, accuracy by size and
    position, example signatures, comparison.json, demo.json). Outputs of an earlier demo
    there are refused unless ``force``; nothing is ever deleted."""
    from ..files import existing_outputs
    from ..learn.models import save_model
    from .reports import (
        REPORT_FILES,
        plot_signatures,
        report_dir,
        write_evaluation_report,
        write_json,
    )

    say = log or (lambda _msg: None)
    if train_per_shape < 2 or test_per_shape < 1:
        raise UsageError("the demo needs at least 2 training and 1 test grasp per shape")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise UsageError(f"report path {out} exists and is not a directory")
    n = len(DEMO_SHAPES)
    planned = {"train": n * train_per_shape, "test": n * test_per_shape}
    for name, size in planned.items():
        check_record_folder(out / name, size, force)
    existing_outputs(out, ("model.npz",), "--out", force)
    existing_outputs(out / "report", REPORT_FILES + DEMO_REPORT_FILES, "--out", force)
    out = report_dir(out)
    report = report_dir(out / "report")
    started = time.perf_counter()
    rng = np.random.default_rng(seed)
    say(f"simulating {len(DEMO_SHAPES) * train_per_shape} training grasps "
        f"({plural(workers, 'worker')})")
    ctl = ControllerSettings(engine=engine)
    train_set = simulate_set(
        train_per_shape, TRAIN_FRACTIONS, TRAIN_OFFSETS, rng, workers, show, "train grasps",
        controller=ctl,
    )  # fmt: skip
    say(f"simulated {len(train_set.records)} training grasps; now the test set at unseen sizes")
    test_set = simulate_set(
        test_per_shape, TEST_FRACTIONS, TEST_OFFSETS, rng, workers, show, "test grasps",
        controller=ctl,
    )  # fmt: skip
    train_records, test_records = train_set.records, test_set.records
    sim_time = time.perf_counter() - started
    if len({r.shape for r in train_records}) < 2 or not test_records:
        raise UsageError("too few grasps could be simulated to train and test a model")
    # the grasps are the expensive part: on disk before any learning, for reuse with
    # `train --data OUT/train` and `evaluate --data OUT/test`
    save_records(train_records, out / "train", force)
    save_records(test_records, out / "test", force)

    say(f"simulated {len(test_records)} test grasps; training signature + svm and comparing "
        f"{len(classifiers)} classifiers")  # fmt: skip
    model = train(train_records, "signature", "svm")
    model.info.update({"made_by": "demo", "seed": int(seed), "train_records": len(train_records)})
    model_path = save_model(out / "model.npz", model)
    result = evaluate(model, test_records)
    comparison = compare(  # without each pair's doubt: 3 more fits a pair, the demo stays quick
        train_records, test_records, ("signature",), [c for c in classifiers], seed=seed,
        doubt=False,
    )  # fmt: skip
    write_evaluation_report(result, report)
    plot_signatures(train_records, report / "signatures.png")
    write_json(report / "comparison.json", comparison)
    doc = {
        "accuracy": result["accuracy"],
        "classes": result["classes"],
        "confusion_matrix": result["confusion_matrix"],
        "per_class": result["per_class"],
        "by_size": result.get("by_size", {}),
        "by_position": result.get("by_position", {}),
        "by_rotation": result.get("by_rotation", {}),
        "bins": result.get("bins", {}),
        "ambiguous": result.get("ambiguous"),
        "engine": engine,
        "train_records": len(train_records),
        "test_records": len(test_records),
        "refused_poses": len(train_set.refused) + len(test_set.refused),
        "no_contact": train_set.no_contact + test_set.no_contact,
        "report": str(report),
        "model": str(model_path),
        "data": {"train": str(out / "train"), "test": str(out / "test")},
        "comparison": comparison,
        "seed": int(seed),
        "simulation_time_s": sim_time,
        "wall_time_s": time.perf_counter() - started,
    }
    write_json(report / "demo.json", doc)
    return doc


def demo_text(doc: Mapping[str, Any]) -> str:
    """What ``demo`` prints on a terminal."""
    from .reports import confusion_text

    lines = [
        f"trained signature + svm on {doc['train_records']} grasps; tested on "
        f"{doc['test_records']} grasps at sizes and offsets not seen in training",
        "",
        confusion_text(doc["confusion_matrix"], doc["classes"]),
        "",
        f"accuracy (signature + svm): {100 * doc['accuracy']:.1f}%",
    ]
    for row in doc.get("comparison", []):
        if row.get("accuracy") is None:
            continue
        lines.append(
            f"  {row['descriptor']} + {row['classifier']}: {100 * row['accuracy']:.1f}% "
            f"(fit {row['fit_time_s']:.2f} s, {row['predict_latency_ms']:.2f} ms per grasp)"
        )
    if doc.get("refused_poses") or doc.get("no_contact"):
        lines.append(
            f"replaced by fresh draws: {doc['refused_poses']} poses the simulator refused "
            f"(object overlapping the open hand), {doc['no_contact']} grasps without contact"
        )
    lines.append(f"report: {doc['report']}  model: {doc['model']}")
    lines.append(f"grasps: {doc['data']['train']} (train), {doc['data']['test']} (test)")
    lines.append(f"wall time: {doc['wall_time_s']:.0f} s")
    return "\n".join(lines) + "\n"
