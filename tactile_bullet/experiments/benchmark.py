"""The recognition benchmark: descriptor x classifier x training x protocol, one table.

``run_benchmark`` simulates the sets the chosen protocols need (``experiments/protocols.py``)
through the dataset layer into a cache folder (sharded, resumable: a killed run continues where it
stopped), fits every descriptor x classifier pair once per training set and training regime,
scores each on every level of every protocol, and writes into ``out``:

- ``benchmark.json``: the configuration, the rows and what was simulated;
- ``noise.png`` / ``shift.png``: accuracy against sensor error and against physics shift;
- ``table.txt``: the headline table a terminal shows.

A row is ``{"protocol", "level", "descriptor", "classifier", "training", "accuracy",
"headline", "test_records", "ambiguous"}`` (``ambiguous``: the shares of answers, of right and
of wrong answers flagged by the pair's calibrated doubt, ``learn/doubt.py``): ``training`` is
``clean`` (the simulated grasps as they are) or ``noise-aware`` (each also presented
perturbed, ``robust.augment``) or ``randomized`` (the protocol's training set simulated with
the hand and physics drawn per grasp, ``protocols.randomized_name``; opt-in, it simulates the
training sets once more); exactly one level per protocol is the headline.
"""

from __future__ import annotations

import json
import math
import os
import time
import zlib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..console import plural
from ..errors import UsageError
from ..learn.perturb import perturb_all
from ..learn.trainings import check_training
from ..records import GraspRecord
from . import protocols as P

DEFAULT_TRAININGS: tuple[str, ...] = ("clean", "noise-aware")
QUICK_DESCRIPTORS = ("signature", "raw-joints", "contact-normals", "robust-signature",
                     "robust-joints")  # fmt: skip
QUICK_CLASSIFIERS = ("svm", "knn")
CONFIG = ".benchmark-config.json"
"""Written first: what this folder's results are, checked before a rerun touches them."""
SHARD_SIZE = 8
"""Grasps per shard of a new set (a resumed one keeps its own)."""
OUTPUTS = ("benchmark.json", "noise.png", "shift.png", "table.txt", "data", CONFIG)


def default_descriptors(quick: bool | str) -> list[str]:
    """Every installed descriptor (the cheap built-ins at the quick and tiny scales)."""
    from ..plugins import descriptor_names

    names = descriptor_names()
    small = P.scale_of(quick) != "full"
    return [n for n in QUICK_DESCRIPTORS if n in names] if small else list(names)


def default_classifiers(quick: bool | str) -> list[str]:
    """Every installed classifier (svm and knn at the quick and tiny scales)."""
    from ..plugins import classifier_names

    names = classifier_names()
    small = P.scale_of(quick) != "full"
    return [n for n in QUICK_CLASSIFIERS if n in names] if small else list(names)


def check_names(descriptors: Sequence[str], classifiers: Sequence[str], trainings) -> None:
    """Every name resolves (UsageError naming the first that does not), before any work."""
    from ..plugins import get_classifier, get_descriptor

    if not descriptors or not classifiers:
        raise UsageError("the benchmark needs at least one descriptor and one classifier")
    for name in descriptors:
        get_descriptor(name)
    for name in classifiers:
        get_classifier(name)
    for name in trainings:
        check_training(name)


def prepare_out(out: Path, config: Mapping[str, Any]) -> None:
    """Create ``out`` or reopen it for the same benchmark; refuse (touching nothing) a file, a
    folder of other files, or another benchmark's results."""
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out} exists and is not a directory")
    if out.is_dir():
        others = sorted(p.name for p in out.iterdir() if p.name not in OUTPUTS)
        if others:
            raise UsageError(
                f"--out {out} holds files the benchmark did not write ({others[0]}...): "
                "choose another --out"
            )
        marker = out / CONFIG
        if marker.exists():
            try:
                existing = json.loads(marker.read_text())
            except (OSError, ValueError):
                raise UsageError(f"{marker} is unreadable; refusing to overwrite {out}") from None
            if existing != json.loads(json.dumps(config)):
                differs = [k for k in config if existing.get(k) != config[k]] or ["config"]
                raise UsageError(
                    f"--out {out} holds another benchmark's results (different "
                    f"{', '.join(differs)}); choose another --out"
                )
        elif any(p.name != "data" for p in out.iterdir()):
            raise UsageError(f"--out {out} is not empty and holds no benchmark: choose another")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"cannot create --out {out}: {exc.strerror or exc}") from None
    if not os.access(out, os.W_OK):
        raise UsageError(f"--out {out} is not writable")
    from .reports import write_json

    write_json(out / CONFIG, config)


def simulate_sets(
    specs: Sequence[P.SetSpec], cache: Path, workers: int, show: bool, log: Callable[[str], None]
) -> dict[str, dict[str, Any]]:
    """Generate (or resume, or reuse) each set's dataset under ``cache``."""
    from ..datasets.generate import generate
    from ..datasets.shards import MANIFEST

    done = {}
    for spec in specs:
        path = cache / spec.name
        if not _complete(path, spec):
            log(f"simulating {spec.name} ({plural(len(spec.sweep().tasks(spec.seed)), 'grasp')})")
            resume = (path / MANIFEST).exists()
            # small shards: a killed run loses at most 8 grasps per worker's block
            generate(spec.sweep(), path, workers=workers, resume=resume, seed=spec.seed,
                     progress=show, shard_size=None if resume else SHARD_SIZE)  # fmt: skip
        done[spec.name] = {"path": str(path)}
    return done


def _complete(path: Path, spec: P.SetSpec) -> bool:
    """Whether ``path`` holds every grasp of ``spec`` (anything else goes to ``generate``,
    which resumes a partial set and refuses a different one)."""
    from ..datasets.shards import MANIFEST

    try:
        data = json.loads((path / MANIFEST).read_text())
        config = data["config"]
        done = sum(s["records"] + s["failed"] for s in data["shards"])
        tasks = int(data["tasks"])
    except (OSError, ValueError, KeyError, TypeError):
        return False
    same = config.get("sweep") == spec.sweep().to_dict() and config.get("seed") == spec.seed
    return same and done >= tasks


def load_set(path: str | os.PathLike) -> tuple[list[GraspRecord], int]:
    """Usable records of a set (with their series) and how many grasps touched nothing."""
    from ..datasets.dataset import open_dataset

    records = list(open_dataset(path).records(full=True))
    kept = [r for r in records if "no_contact" not in r.flags]
    return kept, len(records) - len(kept)


def level_seed(protocol: str, level: str, seed: int) -> int:
    """A perturbation seed fixed by the protocol, the level and the benchmark seed."""
    return zlib.crc32(f"{protocol}/{level}/{seed}".encode())


def run_benchmark(
    out: str | os.PathLike,
    protocols: Sequence[str] | str | None = None,
    descriptors: Sequence[str] | None = None,
    classifiers: Sequence[str] | None = None,
    trainings: Sequence[str] = DEFAULT_TRAININGS,
    *,
    quick: bool | str = False,
    workers: int = 2,
    seed: int = 0,
    cache: str | os.PathLike | None = None,
    show: bool = False,
    log: Callable[[str], None] | None = None,
    engine: str = "bullet",
) -> dict[str, Any]:
    """Run the benchmark (module doc); returns the ``benchmark.json`` document. ``quick``:
    True/False (the --quick flag) or a scale name of ``protocols.SCALES``; ``engine`` simulates
    the single-engine protocols' sets (the cross-engine ones use both)."""
    from ..learn.doubt import calibrate_margin, cross_check_accepts
    from ..learn.robust import augment
    from ..plugins import compatible, get_classifier, get_descriptor
    from .reports import write_json, write_text_atomic
    from .training import labels_of

    say = log or (lambda _msg: None)
    started = time.perf_counter()
    names = P.resolve(protocols, engine)
    scale = P.scale_of(quick)
    descriptors = list(descriptors or default_descriptors(quick))
    classifiers = list(classifiers or default_classifiers(quick))
    trainings = list(dict.fromkeys(trainings))
    check_names(descriptors, classifiers, trainings)
    if int(workers) < 1:
        raise UsageError(f"--workers must be >= 1, got {workers}")
    out = Path(out)
    cache_dir = Path(cache) if cache is not None else out / "data"
    config = {
        "protocols": names, "descriptors": descriptors, "classifiers": classifiers,
        "trainings": trainings, "scale": scale, "seed": int(seed),
    } | ({"engine": engine} if engine != "bullet" else {})  # fmt: skip
    prepare_out(out, config)
    table = P.protocols(scale, engine)
    specs = P.needed_sets(names, scale, trainings, engine)
    simulate_sets(specs, cache_dir, int(workers), show, say)

    sets: dict[str, list[GraspRecord]] = {}
    set_info: dict[str, dict[str, Any]] = {}
    for spec in specs:
        sets[spec.name], missed = load_set(cache_dir / spec.name)
        set_info[spec.name] = {"records": len(sets[spec.name]), "no_contact": missed}
    descs = {name: get_descriptor(name) for name in descriptors}
    fitted: dict[tuple, Any] = {}
    thresholds: dict[tuple, dict[str, Any]] = {}
    kept_records: dict[tuple, list[GraspRecord]] = {}
    features: dict[tuple, np.ndarray] = {}

    def train_features(train_set: str, training: str, desc: str) -> tuple[np.ndarray, np.ndarray]:
        key = (train_set, training, desc)
        if key not in features:
            parts = P.train_sets(train_set)
            if training == "randomized":
                parts = [P.randomized_name(name) for name in parts]
            records = [r for name in parts for r in sets[name]]
            if training == "noise-aware":
                records = augment(records, seed=seed)
            features[key] = np.asarray(descs[desc].transform(records), float)
            features[key + ("y",)] = labels_of(records)
            kept_records[key] = records
        return features[key], features[key + ("y",)]

    rows: list[dict[str, Any]] = []
    steps = [(n, lv) for n in names for lv in table[n].levels]
    bar = _bar(len(steps), show)
    for name, level in steps:
        protocol = table[name]
        test = [r for t in level.test for r in sets[t]]
        if not level.sensor.is_clean:
            test = perturb_all(test, level.sensor, level_seed(name, level.name, seed))
        y_test = labels_of(test)
        seconds = None
        for desc in descriptors:
            x_test = np.asarray(descs[desc].transform(test), float) if test else None
            for clf in classifiers:
                if not compatible(desc, clf):
                    continue
                for training in trainings:
                    train_set = level.train or protocol.train
                    key = (train_set, training, desc, clf)
                    if key not in fitted:
                        x, y = train_features(train_set, training, desc)
                        fitted[key] = get_classifier(clf).fit(x, y)
                        thresholds[key] = calibrate_margin(
                            lambda c=clf: get_classifier(c), x, y, seed=seed,
                            records=kept_records[(train_set, training, desc)],
                            classifier=clf,
                        )  # fmt: skip
                    accuracy, doubt = None, None
                    if x_test is not None:
                        second = None
                        if thresholds[key]["cross_check"] is not None:
                            if seconds is None:  # the shape fit's answers, read once a level
                                classes = sorted(str(c) for c in fitted[key].classes_)
                                seconds = cross_check_accepts(test, classes)
                            second = seconds
                        pred, doubt = _scored(fitted[key], x_test, y_test, thresholds[key],
                                              second)  # fmt: skip
                        accuracy = float(np.mean(pred == y_test))
                    rows.append({
                        "protocol": name, "level": level.name, "descriptor": desc,
                        "classifier": clf, "training": training, "accuracy": accuracy,
                        "headline": bool(level.headline), "test_records": len(test),
                        "ambiguous": doubt,
                    })  # fmt: skip
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    doc = {
        "config": config,
        "rows": rows,
        "sets": set_info,
        "train_sets": {n: table[n].train for n in names},
        "wall_time_s": time.perf_counter() - started,
    }
    write_json(out / "benchmark.json", doc)
    write_text_atomic(out / "table.txt", headline_table(rows))
    figures = plot_curves(rows, table, out)
    doc["figures"] = [str(p) for p in figures]
    return doc


def _scored(
    estimator, x_test, y_test, calibration: Mapping[str, Any], seconds=None
) -> tuple[np.ndarray, dict[str, Any]]:
    """Predicted names and the row's ``ambiguous`` figures: the pair's threshold (calibrated
    on held-out folds of its training set, ``learn/doubt.py``), its cross-check (the shape
    fit's answers ``seconds``) and the shares of all, right and wrong answers flagged."""
    from ..learn.doubt import cross_flags, flag_shares, flagged, margins

    threshold = calibration["margin"]
    pred = np.asarray(estimator.predict(x_test)).astype(str)
    classes = [str(c) for c in estimator.classes_]
    proba = np.asarray(estimator.predict_proba(x_test), dtype=float)
    m = margins(proba, np.array([classes.index(n) for n in pred]))[0]
    flags = flagged(m, threshold)
    if seconds is not None:
        flags = flags | cross_flags(pred, seconds)
    shares = flag_shares(flags, pred == np.asarray(y_test).astype(str))
    return pred, {"margin": threshold, "cross_check": calibration["cross_check"], **shares}


def _bar(total: int, show: bool):
    if not show:
        return None
    import sys

    from tqdm import tqdm

    return tqdm(total=total, desc="scoring", unit="level", file=sys.stderr)


def headline_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """Headline accuracy per method (rows) and protocol (columns), best method first."""
    heads = [r for r in rows if r["headline"]]
    protocols = list(dict.fromkeys(r["protocol"] for r in heads))
    methods: dict[tuple, dict[str, float | None]] = {}
    for r in heads:
        methods.setdefault((r["descriptor"], r["classifier"], r["training"]), {})[r["protocol"]] = (
            r["accuracy"]
        )

    def worst(scores: Mapping[str, float | None]) -> float:
        values = [v for v in scores.values() if v is not None]
        return min(values) if values else -1.0

    order = sorted(methods, key=lambda m: -worst(methods[m]))
    head = ["descriptor", "classifier", "training", *protocols, "worst"]
    body = []
    for m in order:
        cells = [f"{100 * v:.1f}" if v is not None else "-"
                 for v in (methods[m].get(p) for p in protocols)]  # fmt: skip
        w = worst(methods[m])
        body.append([*m, *cells, f"{100 * w:.1f}" if w >= 0 else "-"])
    widths = [max(len(str(x)) for x in col) for col in zip(head, *body, strict=True)]
    lines = ["  ".join(str(c).ljust(w) for c, w in zip(row, widths, strict=True)).rstrip()
             for row in (head, *body)]  # fmt: skip
    return "\n".join(lines) + "\n"


def plot_curves(rows, table: Mapping[str, P.Protocol], out: Path) -> list[Path]:
    """``noise.png`` (accuracy vs sensor error) and ``shift.png`` (vs physics shift) as small
    multiples: one row of panels per curve of the protocol, one panel per descriptor, one line
    per classifier and training in it, and the best method over all (thin black) in every
    panel for reference. Error bars are 95% binomial intervals from each level's test-set size:
    with 60 test grasps one grasp is 1.7 points, so wiggles inside the bars are sampling
    noise, not a trend."""
    from .reports import _pyplot, _save

    written = []
    for name, filename in (("sensor-noise", "noise.png"), ("sim-shift", "shift.png")):
        if name not in table or not any(r["protocol"] == name for r in rows):
            continue
        protocol = table[name]
        series = [s for s in dict.fromkeys(lv.series for lv in protocol.levels)
                  if s and s != "clean"]  # fmt: skip
        if not series:  # only headline levels (the tiny scale): no curve to draw
            continue
        curves = {s: _curves(rows, protocol, name, s) for s in series}
        descs = list(dict.fromkeys(m[0] for c in curves.values() for m in c))
        if not descs:
            continue
        written.append(_save(_small_multiples(_pyplot(), name, protocol, curves, descs),
                             out / filename))  # fmt: skip
    return written


def _curves(rows, protocol: P.Protocol, name: str, series: str) -> dict[tuple, list[tuple]]:
    """``{(descriptor, classifier, training): [(x, accuracy %, half-width %)]}`` along one
    curve (its own levels and the clean one), levels without a score left out."""
    levels = sorted((lv for lv in protocol.levels
                     if lv.series in (series, "clean") and lv.x is not None),
                    key=lambda lv: lv.x)  # fmt: skip
    at = {lv.name: lv.x for lv in levels}
    out: dict[tuple, list[tuple]] = {}
    for r in rows:
        if r["protocol"] != name or r["level"] not in at or r["accuracy"] is None:
            continue
        n = max(int(r.get("test_records") or 0), 1)
        acc = float(r["accuracy"])
        half = 196.0 * math.sqrt(acc * (1.0 - acc) / n) + 50.0 / n  # normal + continuity
        out.setdefault((r["descriptor"], r["classifier"], r["training"]), []).append(
            (at[r["level"]], 100.0 * acc, half)
        )
    return {m: sorted(points) for m, points in out.items()}


def _small_multiples(plt, name: str, protocol: P.Protocol, curves, descs: list[str]):
    """The figure of :func:`plot_curves`: per curve a block of panels, one per descriptor
    (at most 4 a row)."""
    clfs = list(dict.fromkeys(m[1] for c in curves.values() for m in c))
    colours = plt.get_cmap("tab10")
    per_block = -(-len(descs) // 4)  # rows of panels a curve takes, at most 4 panels a row
    ncol = -(-len(descs) // per_block)  # as even as the rows allow: 5 -> 3 + 2, not 4 + 1
    nrow = per_block * len(curves)
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.1 * ncol + 0.6, 2.45 * nrow + 1.0),
                             sharey=True, squeeze=False)  # fmt: skip
    for b, (s, methods) in enumerate(curves.items()):
        best = max(methods, key=lambda m: np.mean([p[1] for p in methods[m]]))
        bx, by, _ = zip(*methods[best], strict=True)
        for k in range(per_block * ncol):
            ax = axes[b * per_block + k // ncol][k % ncol]
            if k >= len(descs):
                ax.set_visible(False)
                continue
            desc = descs[k]
            ax.plot(bx, by, color="0.75", lw=4, zorder=0, solid_capstyle="round")
            for m, points in methods.items():
                if m[0] != desc:
                    continue
                xs, ys, hs = zip(*points, strict=True)
                lo = np.minimum(hs, ys)  # the interval stays within 0-100%
                hi = np.minimum(hs, 100.0 - np.asarray(ys))
                ax.errorbar(xs, ys, yerr=[lo, hi], color=colours(clfs.index(m[1]) % 10),
                            ls="-" if m[2] == "clean" else "--", marker="o", ms=3, lw=1.2,
                            elinewidth=0.7, capsize=2, alpha=0.9)  # fmt: skip
            ax.set_ylim(0, 104)
            ax.grid(alpha=0.3)
            ax.set_title(f"{desc} ({s})", fontsize=8.5)
            if k % ncol == 0:
                ax.set_ylabel("accuracy (%)", fontsize=8)
            ax.set_xlabel(protocol.curve or "", fontsize=7.5)
            ax.tick_params(labelsize=7)
        axes[b * per_block][0].text(
            0.03, 0.04, "grey: " + " + ".join(best), transform=axes[b * per_block][0].transAxes,
            fontsize=6.5, va="bottom",
        )  # fmt: skip
    from matplotlib.lines import Line2D

    key = [Line2D([], [], color=colours(k % 10), marker="o", ms=3, label=c)
           for k, c in enumerate(clfs)]  # fmt: skip
    key += [
        Line2D([], [], color="0.3", ls="-", label="clean training"),
        Line2D([], [], color="0.3", ls="--", label="noise-aware training"),
        Line2D([], [], color="0.75", lw=4, label="best method of the curve (named in its "
               "first panel)"),
    ]  # fmt: skip
    fig.legend(handles=key, loc="lower center", ncol=3, fontsize=8, frameon=False,
               bbox_to_anchor=(0.5, 0.0))  # fmt: skip
    fig.suptitle(f"{name}: accuracy per descriptor (bars: 95% interval from the test-set "
                 "size)", fontsize=11)  # fmt: skip
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    return fig
