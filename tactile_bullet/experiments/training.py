"""Fit a method (a descriptor and a classifier from the registry) to grasp records and use
it: read and split the records, train, predict, evaluate, identify one grasp, compare pairs.

Every function takes and returns plain objects (records, models, JSON-ready dicts), so the
CLI is a thin layer over them and scripts call them directly; ``workflow`` re-exports each
name beside the demo. Descriptors and classifiers are looked up by name in the plugin
registry, so a third-party plugin joins every step for free. (What a model is fitted on, the
training regime, is ``learn/trainings.py``.)
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import UsageError
from ..records import GraspRecord

MIN_TRAIN_PER_SHAPE = 2
""":func:`compare` trains every classifier on the same set: each shape needs two grasps (the
svm's calibration folds need two), checked before any pair is fitted."""

LATENCY_SAMPLES = 20
"""Single-grasp predictions timed per pair in :func:`compare` (the median is reported)."""


# --- data ---------------------------------------------------------------------------------------


def records_from(path: str | os.PathLike, allow_partial: bool = False) -> list[GraspRecord]:
    """Every record of a dataset folder (manifest and shards), of a folder of ``.npz`` records,
    or of one ``.npz`` record file. Damaged data (a shard that fails its checksum, a shard
    missing or never generated, an unreadable record file) is an error naming it, unless
    ``allow_partial``: then it is skipped with a
    :class:`~tactile_bullet.datasets.dataset.PartialDataWarning` saying how many records were
    left out (:func:`tactile_bullet.datasets.dataset.read_records` returns them as data)."""
    from ..datasets.dataset import read_records

    loaded = read_records(path, allow_partial)
    loaded.warn()
    return loaded.records


def labels_of(records: Sequence[GraspRecord]) -> np.ndarray:
    """True shape names, the classifiers' targets."""
    return np.array([r.shape for r in records], dtype=object).astype(str)


def _checked(records: Iterable[GraspRecord], what: str) -> list[GraspRecord]:
    records = list(records)
    if not records:
        raise UsageError(f"the {what} set holds no grasp records")
    return records


def split(
    records: Sequence[GraspRecord], test_fraction: float = 0.3, seed: int = 0
) -> tuple[list[GraspRecord], list[GraspRecord]]:
    """Seeded split stratified by shape: every shape keeps its share in both halves."""
    from sklearn.model_selection import train_test_split

    records = _checked(records, "data")
    if not 0.0 < test_fraction < 1.0:
        raise UsageError(f"test fraction must be between 0 and 1, got {test_fraction}")
    y = labels_of(records)
    names, counts = np.unique(y, return_counts=True)
    if len(names) < 2:
        raise UsageError(f"the data holds a single shape ({names[0]}): nothing to tell apart")
    if counts.min() < 2:
        raise UsageError(
            f"shape {str(names[counts.argmin()])!r} has only one record: a split needs at least two"
        )
    n_test = max(len(names), int(round(test_fraction * len(records))))
    if len(records) - n_test < len(names):
        raise UsageError(f"{len(records)} records are too few to split over {len(names)} shapes")
    idx_train, idx_test = train_test_split(
        np.arange(len(records)), test_size=n_test, stratify=y, random_state=seed
    )
    return [records[i] for i in sorted(idx_train)], [records[i] for i in sorted(idx_test)]


# --- train / evaluate / identify ----------------------------------------------------------------


def train(
    records: Iterable[GraspRecord],
    descriptor: str = "signature",
    classifier: str = "svm",
    params: Mapping[str, Any] | None = None,
    descriptor_params: Mapping[str, Any] | None = None,
    doubt: bool = True,
    known: Sequence[GraspRecord] | None = None,
):
    """Fit ``classifier`` (with estimator ``params``) on ``descriptor`` features of the records.

    ``doubt``: also calibrate the model's ambiguity threshold on held-out folds of the records
    (``learn/doubt.py``; costs ``doubt.FOLDS`` more fits), kept in ``info["doubt"]``.
    ``known``: grasps of the user's hand (already among ``records``, ``train --known``) kept
    in the model to second its answers in place of the shape fit (``doubt.KnownGrasps``).

    Returns a :class:`tactile_bullet.learn.models.Model` that remembers both names and
    parameters, so a saved model rebuilds the same features when it is loaded elsewhere."""
    from ..learn.models import Model
    from ..plugins import get_descriptor

    records = _checked(records, "training")
    y = labels_of(records)
    if len(set(y)) < 2:
        raise UsageError(f"training needs at least two shapes, the data holds only {str(y[0])!r}")
    desc = get_descriptor(descriptor, **dict(descriptor_params or {}))
    estimator = _estimator(classifier, params)  # names and parameters checked before work
    reason = _incompatible(desc.name, classifier)
    if reason:
        raise UsageError(f"cannot train {classifier} on the {desc.name} descriptor: {reason}")
    x = np.asarray(desc.transform(records), dtype=float)
    estimator = _fit(estimator, classifier, bool(params), x, y)
    info: dict[str, Any] = {}
    reference = None
    if known:
        from ..learn.doubt import KnownGrasps

        reference = KnownGrasps.from_records(_checked(known, "known"))
    from ..learn.novelty import calibration_groups, grasp_groups, midpoint_pairs

    groups = grasp_groups(records)  # noise-aware copies of a grasp held out together
    if doubt:
        from ..learn.doubt import model_doubt

        # the ambiguity threshold, set on grasps each held out of a fit (learn/doubt.py)
        make = lambda: _estimator(classifier, params)  # noqa: E731
        info["doubt"] = model_doubt(make, x, y, records, classifier, reference, groups)
    novelty = _novelty(x, y, calibration_groups(records, groups=groups), midpoint_pairs(records))
    if novelty is not None:
        info["novelty"] = novelty.summary()
    from ..perception.contact_check import ContactCheck

    axis = ContactCheck.fit(records, y, groups)  # None where the grasps have no contacts
    return Model(
        descriptor=desc.name,
        descriptor_params=dict(desc.params),
        classifier=classifier,
        classifier_params=dict(params or {}),
        estimator=estimator,
        info=info,
        known=reference,
        novelty=novelty,
        axis=axis,
    )


def _novelty(x: np.ndarray, y: np.ndarray, groups: np.ndarray | None = None,
             pairs: np.ndarray | None = None):  # fmt: skip
    """The model's :class:`~tactile_bullet.learn.novelty.Novelty` (answers ``unknown`` where a
    grasp lies far from every training grasp), None where too few grasps calibrate it;
    ``groups``: copies of one grasp held out together; ``pairs``: grasps of neighbouring
    sizes whose midpoints join the reference."""
    from ..learn.novelty import Novelty

    try:
        return Novelty.fit(x, y, groups=groups, pairs=pairs)
    except ValueError:
        return None


def _estimator(classifier: str, params: Mapping[str, Any] | None):
    from ..plugins import get_classifier

    try:
        return get_classifier(classifier, **dict(params or {}))
    except TypeError as exc:
        raise UsageError(f"classifier {classifier!r} rejected its parameters: {exc}") from None


def _fit(estimator, classifier: str, user_params: bool, features: np.ndarray, y: np.ndarray):
    """Fit, blaming the user's parameters (UsageError) when the estimator rejects them."""
    try:
        return estimator.fit(features, y)
    except (ValueError, TypeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        if user_params:
            raise UsageError(
                f"classifier {classifier!r} rejected its parameters: {first}"
            ) from None
        if isinstance(exc, TypeError):
            raise
        # scikit-learn's convention: fit raises ValueError for data it cannot learn from
        # (too few samples of a class, ...): the user's data, not a bug
        raise UsageError(
            f"classifier {classifier!r} cannot be trained on this data: {first}"
        ) from None


def predict(model, records: Sequence[GraspRecord]) -> np.ndarray:
    """Shape names the model gives the records."""
    return np.asarray(model.predict_records(list(records))).astype(str)


def evaluate(model, records: Iterable[GraspRecord]) -> dict[str, Any]:
    """Score a model on labelled records: the ``evaluate --json`` document (docs/json.md)
    with accuracy by object size and by position, and which model was scored."""
    from .reports import class_order, evaluation_report

    records = _checked(records, "test")
    y_true = labels_of(records)
    known = [str(c) for c in model.classes]
    if not set(y_true) & set(known):
        raise UsageError(
            f"the data's shapes ({', '.join(sorted(set(y_true)))}) are none of the model's "
            f"classes ({', '.join(known)})"
        )
    x = model.features(records)
    y_pred, proba, renamed_from = model.answers(records, x)
    y_pred = np.asarray(y_pred).astype(str)
    doc = evaluation_report(y_true, y_pred, class_order(known, y_true), records)
    from ..learn.doubt import evaluation_doubt

    doc["ambiguous"] = evaluation_doubt(model, records, y_true, y_pred, proba, features=x,
                                        renamed_from=renamed_from)  # fmt: skip
    # grasps of no family the model knows, counted apart from the family's (learn/novelty.py)
    doc["unknown"] = doc["ambiguous"].pop("unknown")
    unknown = sorted(set(y_true) - set(known))
    if unknown:
        doc["unknown_classes"] = unknown
    from ..perception.contact import nothing_to_identify

    # scored like every grasp (a model answers them all), but counted: a grasp that touched
    # nothing carries no shape, and `identify` names none
    doc["no_contact"] = sum(nothing_to_identify(r) is not None for r in records)
    doc["model"] = describe_model(model)
    engines = sorted({r.controller.engine for r in records if r.source == "simulated"})
    if engines and engines != ["bullet"]:  # another engine, or a mix: the report says so
        doc["engines"] = engines
    return doc


def describe_model(model) -> dict[str, Any]:
    return {
        "descriptor": model.descriptor,
        "descriptor_params": dict(model.descriptor_params),
        "classifier": model.classifier,
        "classifier_params": dict(model.classifier_params),
        "classes": [str(c) for c in model.classes],
    }


def identify(model, record: GraspRecord) -> dict[str, Any]:
    """Name the shape of one grasp: ``{"shape", "probabilities": {class: p}, "margin",
    "ambiguous"}`` (``ambiguous`` ``[shape, runner-up]`` where the two best are within the
    model's calibrated margin, else None: ``learn/doubt.py``); a grasp that touched too little
    gets no name: ``{"shape": None, "reason", "probabilities": {}, "margin": None,
    "ambiguous": None}`` (:mod:`tactile_bullet.perception.contact`)."""
    from ..perception.contact import nothing_to_identify

    reason = nothing_to_identify(record)
    if reason is not None:
        from ..learn.doubt import no_doubt

        return {"shape": None, "reason": reason, "probabilities": {}, **no_doubt()}
    classes = [str(c) for c in model.classes]
    x = model.features([record])
    names, proba, renamed_from = model.answers([record], x)
    shape = str(names[0])
    if proba is None:
        probabilities = {c: float(c == shape) for c in classes}
    else:
        probabilities = {c: float(p) for c, p in zip(classes, proba[0], strict=True)}
    from ..learn.doubt import doubts

    (doubt,) = doubts(model, [record], [shape], proba, features=x, renamed_from=renamed_from)
    return {"shape": shape, "probabilities": probabilities, **doubt}


# --- compare ------------------------------------------------------------------------------------


def compare(
    train_records: Iterable[GraspRecord],
    test_records: Iterable[GraspRecord] | None = None,
    descriptors: Sequence[str] = ("signature",),
    classifiers: Sequence[str] = ("svm",),
    seed: int = 0,
    test_fraction: float = 0.3,
    on_pair: Callable[[dict[str, Any]], None] | None = None,
    doubt: bool = True,
) -> list[dict[str, Any]]:
    """Accuracy and cost of every descriptor x classifier pair on the same train/test data.

    ``doubt``: each row also gets ``ambiguous`` (``learn.doubt.pair_doubt``: the pair's threshold,
    calibrated on held-out folds of the training set, and the shares of test answers flagged).

    Without ``test_records`` the training records are split (seeded, stratified by shape).
    ``fit_time_s`` is the classifier's fit on precomputed features; ``predict_latency_ms`` the
    median time to identify one grasp from its record (descriptor plus prediction), the figure
    that matters on a robot. A pair that cannot work together (``dtw-template`` on anything but
    the signature) is listed with ``accuracy`` None and the reason under ``skipped``."""
    from ..plugins import get_descriptor

    train_records = _checked(train_records, "training")
    if test_records is None:
        train_records, test_records = split(train_records, test_fraction, seed)
    test_records = _checked(test_records, "test")
    if not descriptors or not classifiers:
        raise UsageError("compare needs at least one descriptor and one classifier")
    y_train, y_test = labels_of(train_records), labels_of(test_records)
    if len(set(y_train)) < 2:
        raise UsageError("training needs at least two shapes")
    names, counts = np.unique(y_train, return_counts=True)
    if counts.min() < MIN_TRAIN_PER_SHAPE:
        raise UsageError(
            f"shape {str(names[counts.argmin()])!r} has {int(counts.min())} training grasp(s); "
            f"compare needs at least {MIN_TRAIN_PER_SHAPE} per shape (more data, or --test)"
        )
    # resolve every name up front so a typo fails before minutes of fitting
    descs = [get_descriptor(d) for d in descriptors]
    _check_classifiers(classifiers)
    reasons = [_incompatible(d.name, c) for d in descs for c in classifiers]
    if all(reasons):  # nothing to compare: say why now, not in a table of dashes
        raise UsageError(f"no descriptor x classifier pair can run: {reasons[0]}")
    from ..console import tick
    from ..learn.doubt import pair_doubt

    seconds: dict[str, np.ndarray] = {}  # the shape fit's answers on the test set, read once
    rows = []
    for desc in descs:
        x_train, x_test = desc.transform(train_records), desc.transform(test_records)
        for name in classifiers:
            tick("descriptor x classifier pairs fitted", len(rows), len(descs) * len(classifiers))
            reason = _incompatible(desc.name, name)
            if reason:
                rows.append(_skipped_row(desc.name, name, reason, train_records, test_records))
                continue
            start = time.perf_counter()
            estimator = _fit(_estimator(name, None), name, False, x_train, y_train)
            fit_time = time.perf_counter() - start
            y_pred = np.asarray(estimator.predict(x_test)).astype(str)
            row = {
                "descriptor": desc.name,
                "classifier": name,
                "accuracy": float(np.mean(y_pred == y_test)),
                "fit_time_s": fit_time,
                "predict_latency_ms": _latency_ms(desc, estimator, test_records),
                "train_records": len(train_records),
                "test_records": len(test_records),
                "skipped": None,  # every row the same fields: a run pair skipped nothing
            }
            row["ambiguous"] = None
            if doubt:
                trained, tested = (x_train, y_train, train_records), (x_test, y_test, test_records)
                row["ambiguous"] = pair_doubt(name, estimator, trained, tested, seconds)
            rows.append(row)
            if on_pair is not None:
                on_pair(row)
    return rows


def _incompatible(descriptor: str, classifier: str) -> str | None:
    """Why a classifier cannot read a descriptor's features (``dtw-template`` reads only the
    signature), or None when it can."""
    from .. import plugins

    accepted = plugins.accepted_descriptors(classifier)
    if accepted is None or descriptor in accepted:
        return None
    return f"{classifier} reads only the {' or '.join(accepted)} descriptor"


def _skipped_row(descriptor, classifier, reason, train_records, test_records) -> dict[str, Any]:
    return {
        "descriptor": descriptor,
        "classifier": classifier,
        "accuracy": None,
        "fit_time_s": None,
        "predict_latency_ms": None,
        "train_records": len(train_records),
        "test_records": len(test_records),
        "skipped": reason,
        "ambiguous": None,
    }


def _check_classifiers(names: Sequence[str]) -> None:
    from ..plugins import get_classifier

    for name in names:
        get_classifier(name)


def _latency_ms(desc, estimator, records: Sequence[GraspRecord]) -> float:
    times = []
    for rec in list(records)[:LATENCY_SAMPLES]:
        start = time.perf_counter()
        estimator.predict(desc.transform([rec]))
        times.append(time.perf_counter() - start)
    return 1000.0 * float(np.median(times))


# --- demo ---------------------------------------------------------------------------------------
