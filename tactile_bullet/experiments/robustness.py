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
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import UsageError
from ..records import GraspRecord
from .robustness_sets import (  # noqa: F401 - the matrix's names, re-exported
    AMBIGUOUS_OBJECTS,
    COLUMN_NAMES,
    COLUMNS,
    FAMILY_OBJECTS,
    LEARNT,
    NO_FAMILY_OBJECTS,
    NOISE,
    NOISE_AWARE,
    OTHER_HANDS,
    OUT_OF_FAMILY,
    OUT_OF_FAMILY_SETS,
    OUT_OF_FAMILY_SHAPES,
    OUT_OF_FAMILY_VALIDATION,
    POSED_X,
    POSED_Z,
    RANDOMIZED,
    SCALES,
    SHAPES,
    TRAININGS,
    TURNED_DEG,
    VALIDATION_OBJECTS,
    Column,
    SweepSet,
    _labels,
    parse_hands,
    plugin_shapes,
    read_column,
    replayed,
    set_specs,
    write_objects,
)


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

SEEN: dict[str, tuple[str, ...]] = {
    "finger-points": ("menagerie", "gymnasium"),
    "coupled-finger-points": ("menagerie", "gymnasium"),
    "mujoco-randomized": ("gymnasium",),
    "both-randomized": ("gymnasium",),
    "posed-randomized": ("gymnasium", "poses", "turned", "household"),
    "both+posed-randomized": ("gymnasium", "poses", "turned", "household", "mujoco", "j0-only"),
    "both+posed-noise-aware": ("gymnasium", "poses", "turned", "household", "mujoco", "j0-only",
                               "noise"),
}
"""Descriptor or training -> columns it was chosen after seeing (rule 2): marked ``*`` and
left out of its score."""


def select_candidates(descriptors: str | Sequence[str] | None,
                      classifiers: str | Sequence[str] | None) -> list[Candidate]:  # fmt: skip
    """The candidates whose descriptor and classifier are among the comma lists given (a
    repeated flag's lists joined; all where None); a UsageError where none is left."""
    def names(text):
        if text is not None and not isinstance(text, str):
            text = ",".join(text)
        return None if not text else {n.strip() for n in text.split(",") if n.strip()}

    descs, clfs = names(descriptors), names(classifiers)
    chosen = [c for c in CANDIDATES if (descs is None or c.descriptor in descs)
              and (clfs is None or c.classifier in clfs)]  # fmt: skip
    if not chosen:
        raise UsageError("no candidate method of docs/robustness.md matches --descriptor "
                         "and --classifier")  # fmt: skip
    return chosen


HAND_COLUMNS = frozenset(OTHER_HANDS)
"""On replicate sets only the hands stay seen: their grasps are new, the hands are not."""


def seen_columns(candidate: Candidate, training: str, replicate: int = 0) -> set[str]:
    """The columns that do not count toward this method's score (on a replicate run, only the
    hands written by others that it was chosen after seeing)."""
    seen = set(SEEN.get(candidate.descriptor, ())) | set(SEEN.get(training, ()))
    return seen & HAND_COLUMNS if replicate else seen


# --- scoring -------------------------------------------------------------------------------------


@dataclass
class _Fitted:
    estimator: Any
    calibration: dict[str, Any]
    novelty: Any
    axis: Any = None


def _shape_fit_accepts(records, cache: dict[int, tuple], classes) -> list[tuple[str, ...]]:
    """The families the shape fit accepts for each record, each read once per run (keyed by
    identity; ``learn/doubt.cross_check_accepts``)."""
    from ..learn.doubt import cross_check_accepts

    todo = [r for r in records if id(r) not in cache]
    for r, found in zip(todo, cross_check_accepts(todo, classes), strict=True):
        cache[id(r)] = found
    return [cache[id(r)] for r in records]


def _default_meta() -> dict[str, Any]:
    """The shipped default's description, {} where it cannot be read."""
    from ..learn.default import default_meta

    try:
        return default_meta()
    except UsageError:
        return {}


def shipped_second(cand: Candidate, training: str,
                   meta: Mapping[str, Any] | None = None) -> dict[str, str] | None:  # fmt: skip
    """The second opinion (``{"descriptor", "classifier"}``) of the shipped default where
    ``cand`` on ``training`` is the shipped default's method (``meta``: its description, read
    here when not given), else None: that row's doubt is then seconded as the shipped default's
    answers are (``learn/second_opinion.py``), every other row's by the shape fit, as a model
    users train is."""
    meta = _default_meta() if meta is None else meta
    second = meta.get("second_opinion")
    same = (cand.descriptor, dict(cand.params), cand.classifier, training) == \
        (meta.get("descriptor"), meta.get("params") or {}, meta.get("classifier"),
         meta.get("training"))  # fmt: skip
    return dict(second) if same and isinstance(second, dict) else None


def score_matrix(
    sets: Mapping[str, list[GraspRecord]],
    candidates: Sequence[Candidate],
    seed: int = 0,
    log: Callable[[str], None] | None = None,
    replicate: int = 0,
) -> list[dict[str, Any]]:
    """One row per candidate and training: accuracy, doubt and unknown share per column (None
    with a ``reason`` where the method cannot run there), its score and its eligibility."""
    from ..learn.doubt import cross_flags, flagged, margins
    from ..learn.models import renamed
    from ..plugins import compatible, get_descriptor

    say = log or (lambda _m: None)
    columns = [c for c in COLUMNS if all(s in sets for s in c.sets)]
    tests = {c.name: read_column(c, sets, seed) for c in columns}
    oof = {n: sets[n] for n in OUT_OF_FAMILY_SETS if n in sets}
    fit_cache: dict[int, str] = {}
    axis_cache: dict = {}  # contacts residuals: axis by array id, profile by (id, family)
    rows = []
    meta = _default_meta()  # which row is the shipped default's, read once
    runs = [(c, t) for c in candidates for t in c.trainings]
    for i, (cand, training) in enumerate(runs, 1):
        started = time.perf_counter()
        row: dict[str, Any] = {"method": cand.label, "descriptor": cand.descriptor,
                               "params": dict(cand.params), "classifier": cand.classifier,
                               "training": training, "plugin": cand.plugin, "columns": {},
                               "seen": sorted(seen_columns(cand, training, replicate))}  # fmt: skip
        if not compatible(cand.descriptor, cand.classifier):
            continue
        desc = get_descriptor(cand.descriptor, **dict(cand.params))
        train = training_set(sets, training, seed)
        y = _labels(train)
        x = np.asarray(desc.transform(train), float)
        fitted = _fit(cand, x, y, train, seed, fit_cache, axis_cache)
        classes = [str(c) for c in fitted.estimator.classes_]
        second = shipped_second(cand, training, meta)
        if second is not None:  # the shipped default's row: its own second svm seconds it
            from ..learn.second_opinion import SecondOpinion

            second = SecondOpinion.fit(train, y, second["descriptor"], second["classifier"])
        row["second_opinion"] = "shape-fit" if second is None else \
            f"{second.descriptor} + {second.classifier}"  # fmt: skip
        for col, name in [*((c, c.name) for c in columns), *((None, n) for n in oof)]:
            records = tests[name] if col else oof[name]
            reason = _cannot_read(cand, records)
            if reason:
                row["columns"][name] = {"accuracy": None, "reason": reason}
                continue
            xt = np.asarray(desc.transform(records), float)
            pred = np.asarray(fitted.estimator.predict(xt)).astype(str)
            was = pred
            if fitted.axis is not None:  # a torus read as a sphere, named by its contacts
                pred = renamed(pred, fitted.axis.contact_names(
                    records, pred, lambda recs: _residuals(recs, axis_cache),
                    lambda recs, names: _profiles(recs, names, axis_cache),
                    lambda recs: _tori(recs, axis_cache)))  # fmt: skip
            proba = np.asarray(fitted.estimator.predict_proba(xt), float)
            m = margins(proba, np.array([classes.index(p) for p in pred]))[0]
            # an answer its contacts renamed is ambiguous, as the answers say (learn/doubt.py)
            flags = flagged(m, fitted.calibration.get("margin")) | (pred != was)
            if second is not None:
                flags |= np.array(second.names(records)).astype(str) != pred
            elif fitted.calibration.get("cross_check") is not None:
                flags |= cross_flags(pred, _shape_fit_accepts(records, fit_cache, classes))
            unknown = fitted.novelty.unknown(xt) if fitted.novelty is not None else \
                np.zeros(len(xt), bool)  # fmt: skip
            if fitted.axis is not None:  # contacts that fit no family's solid or profile
                unknown |= fitted.axis.unknown(
                    records, pred, lambda recs: _residuals(recs, axis_cache),
                    lambda recs, names: _profiles(recs, names, axis_cache))  # fmt: skip
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


def _fit(cand: Candidate, x: np.ndarray, y: np.ndarray, train, seed: int,
         fit_cache: dict[int, str], axis_cache: dict) -> _Fitted:  # fmt: skip
    """The candidate fitted on one training, its doubt calibrated (the shape fit's answers read
    once a run) and its novelty."""
    from ..learn.doubt import calibrate_margin
    from ..learn.novelty import Novelty, calibration_groups, grasp_groups, midpoint_pairs
    from ..plugins import get_classifier

    groups = grasp_groups(train)  # noise-aware copies of a grasp held out together
    estimator = get_classifier(cand.classifier).fit(x, y)
    if cand.classifier == "shape-fit":
        calibration: dict[str, Any] = {"margin": None, "cross_check": None}
    else:
        calibration = calibrate_margin(lambda: get_classifier(cand.classifier), x, y,
                                       seed=seed, records=train, classifier=cand.classifier,
                                       accepts=lambda recs, cls: _shape_fit_accepts(
                                           recs, fit_cache, cls), groups=groups)  # fmt: skip
    try:
        novelty = Novelty.fit(x, y, seed=seed, groups=calibration_groups(train, groups=groups),
                              pairs=midpoint_pairs(train, seed))
    except ValueError:
        novelty = None
    from ..perception.contact_check import ContactCheck

    return _Fitted(estimator, calibration, novelty,
                   ContactCheck.fit(train, y, groups,
                                 residuals=lambda recs: _residuals(recs, axis_cache),
                                 profiles=lambda recs, names: _profiles(recs, names, axis_cache)))


def _profiles(records, names, cache: dict) -> list[float | None]:
    """Each record's profile residual for the family named, computed once a run per record and
    family (batched; keyed as :func:`_once` keys, by the family's name)."""
    from ..perception.profile_fit import profile_residuals

    todo = {}
    for r, name in zip(records, names, strict=True):
        key = (id(r.contact_position), str(name))
        if key not in cache:
            todo[key] = r
    values = profile_residuals(list(todo.values()), [k[1] for k in todo])
    for (key, r), value in zip(todo.items(), values, strict=True):
        cache[key] = (r.contact_position, value)
    return [cache[(id(r.contact_position), str(n))][1] for r, n in zip(records, names, strict=True)]


def _tori(records, cache: dict) -> list[float | None]:
    """Each record's torus residual (``profile_fit.torus_residuals``), computed once a run."""
    from ..perception.profile_fit import torus_residuals

    return _once(records, cache, "torus-fit", torus_residuals)


def _residuals(records, cache: dict) -> list[float | None]:
    """Each record's axis residual (``revolution.axis_residuals``), computed once a run."""
    from ..perception.revolution import axis_residuals

    return _once(records, cache, "axis", axis_residuals)


def _once(records, cache: dict, what: str, compute) -> list[float | None]:
    """``compute`` (batched) of each record not yet in ``cache``, then every record's value:
    keyed by its contacts array, which every candidate's copy of a test set shares (the array
    is kept in the cache, so its id is not reused), and ``what`` was computed."""
    todo = {id(r.contact_position): r for r in records
            if (id(r.contact_position), what) not in cache}  # fmt: skip
    for (key, r), value in zip(todo.items(), compute(list(todo.values())), strict=True):
        cache[(key, what)] = (r.contact_position, value)
    return [cache[(id(r.contact_position), what)][1] for r in records]


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


def pooled(runs: Sequence[Sequence[Mapping[str, Any]]]) -> list[dict[str, Any]]:
    """The rows of several replicate runs of the matrix as one: each method and training's
    accuracy and unknown share per column pooled over the runs (weighted by their grasps: the
    share of all their grasps), then scored by the same rule. A method that is n/a on a column
    in any run is n/a there; a column seen in any run stays uncounted. Only the methods every
    run scored are kept (docs/robustness.md, the pooled rule)."""
    def key(row):
        return (row["descriptor"], json.dumps(row["params"], sort_keys=True), row["classifier"],
                row["training"])  # fmt: skip

    tables = [{key(r): r for r in rows} for rows in runs]
    out = []
    for k in [key(r) for r in runs[0] if all(key(r) in t for t in tables[1:])]:
        rows = [t[k] for t in tables]
        first = rows[0]
        row: dict[str, Any] = {name: first[name] for name in
                               ("method", "descriptor", "params", "classifier", "training",
                                "plugin")}  # fmt: skip
        row["seen"] = sorted(set().union(*(r["seen"] for r in rows)))
        row["columns"] = {}
        for name in first["columns"]:
            cells = [r["columns"].get(name) for r in rows]
            if any(c is None or c.get("n") is None for c in cells):
                reason = next((c.get("reason") for c in cells if c and c.get("reason")), None)
                row["columns"][name] = {"accuracy": None, "reason": reason or "not in every run"}
                continue
            n = sum(c["n"] for c in cells)
            cell: dict[str, Any] = {"n": n}
            if all(c.get("unknown") is not None for c in cells):
                cell["unknown"] = sum(c["n"] * c["unknown"] for c in cells) / n
            if all(c.get("accuracy") is not None for c in cells):
                cell["accuracy"] = sum(c["n"] * c["accuracy"] for c in cells) / n
            elif any("accuracy" in c for c in cells):
                cell["accuracy"] = None
            row["columns"][name] = cell
        _summarise(row)
        out.append(row)
    return out


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
    replicate: int = 0,
) -> dict[str, Any]:
    """Simulate every set (cached, resumable), score every candidate, write ``robustness.json``
    and ``table.md`` under ``out``, and return the document. ``replicate`` k > 0: every test
    set drawn afresh (robustness_sets.set_specs), the training sets kept."""
    from .benchmark import load_set, prepare_out, simulate_sets
    from .reports import write_json, write_text_atomic

    if scale not in SCALES:
        raise UsageError(f"unknown scale {scale!r} (known: {', '.join(SCALES)})")
    if isinstance(replicate, bool) or not isinstance(replicate, int) or not 0 <= replicate <= 99:
        raise UsageError(f"--replicate must be a whole number from 0 to 99, got {replicate!r}")
    say = log or (lambda _m: None)
    started = time.perf_counter()
    hands = dict(hands or {})
    out = Path(out)
    cache_dir = Path(cache) if cache is not None else out / "data"
    chosen = _available(candidates or CANDIDATES)
    config = {"protocols": ["robustness"], "scale": scale, "seed": int(seed),
              "hands": {k: str(Path(v).resolve()) for k, v in sorted(hands.items())},
              "methods": [c.label for c in chosen], "replicate": int(replicate)}  # fmt: skip
    prepare_out(out, config)
    objects = write_objects(cache_dir / "objects")
    specs = set_specs(scale, hands, objects, plugin_shapes(), replicate)
    simulate_sets(list(specs.values()), cache_dir, int(workers), show, say)
    sets: dict[str, list[GraspRecord]] = {}
    for short, spec in specs.items():
        sets[short], _missed = load_set(cache_dir / spec.name)
    simulated = time.perf_counter() - started
    rows = score_matrix(sets, chosen, seed=seed, log=say, replicate=replicate)
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
    records: Sequence[GraspRecord], info: Mapping[str, Any] | None = None,
):  # fmt: skip
    """A saved-model-ready :class:`~tactile_bullet.learn.models.Model` of one method on
    ``records``, as ``train`` makes it (its doubt and novelty calibrated on held-out folds),
    with ``info`` and the number of training grasps added; what
    ``tools/make_default_model.py`` ships."""
    from .training import train

    model = train(records, descriptor, classifier, descriptor_params=dict(params))
    model.info.update({**dict(info or {}), "train_records": len(records)})
    return model


def training_set(sets: Mapping[str, list[GraspRecord]], training: str,
                 seed: int = 0, noisy: bool = True) -> list[GraspRecord]:  # fmt: skip
    """The records a training fits on: its sets joined, and for a noise-aware training each
    record also presented through joint noise (``learn/robust.augment``, seeded; ``noisy``
    False: the grasps alone)."""
    records = [r for s in TRAININGS[training] for r in sets[s]]
    if noisy and training in NOISE_AWARE:
        from ..learn.robust import augment

        records = augment(records, seed=seed)
    return records


def training_records(cache: Path, scale: str, training: str, seed: int = 0,
                     noisy: bool = True) -> list[GraspRecord]:  # fmt: skip
    """The records of one of the matrix's trainings, read from its cache (augmented where
    the training is noise-aware, as the matrix scored it, unless ``noisy`` is False)."""
    from .benchmark import load_set

    specs = set_specs(scale, {}, None)
    sets = {short: load_set(cache / specs[short].name)[0] for short in TRAININGS[training]}
    return training_set(sets, training, seed, noisy)
