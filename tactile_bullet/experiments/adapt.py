"""``tactile-bullet adapt``: from a hand's known grasps to its model, in one command.

The candidate ways (measured on hands written by others in docs/robustness.md and
``benchmarks/known_grasps.py``), each scored by cross-validation on the known grasps alone:

- ``default``: the default identifier as shipped (``learn/default.py``). It is fitted without
  any known grasp, so its score is its accuracy on all of them.
- ``nearest-known``: the nearest known grasp, one neighbour on ``signature+coupled-joints``,
  fitted on the known grasps alone.
- ``default-shifted``: the default's own training grasps moved by the hand's mean feature
  offset, with the known grasps added five times over, an SVM on the default's descriptor
  (``coupled-finger-points``). The offset is the mean over shapes of (mean of the known grasps
  of a shape - mean of the default's training grasps of that shape). The default's training
  records are not shipped, only their features and labels beside its model file
  (``default_training.npz``, sha256-checked), which this way reads (:func:`default_training`).
- ``train-known`` (only with ``data``, a simulated training set such as a randomised preset):
  the default's method fitted on that set with the known grasps added (``train --known``).
- ``calibrated-shape-fit`` (asked for with ``calibrate=True``, ``adapt --calibrate``; where
  every known shape is one the shape fit models): the
  training-free shape fit with its coefficients refitted to the hand from the known grasps
  (``tactile-bullet calibrate``'s :func:`~tactile_bullet.perception.hand_fit.fit_hand`); the
  model it writes carries those coefficients, so ``identify`` needs no ``--hand-calibration``.
  Inside the cross-validation each fold's calibration tries :data:`CV_STRENGTHS` with 2 inner
  folds (a fit per held-out fold costs 1-3 s); the model it writes is calibrated in full.
  It is not tried unless asked for: on the hands written by others it never named their
  unseen grasps better than the ways above, its leave-one-out score on 2 grasps per shape once
  won the choice and lost 20 points on the unseen grasps, and it makes ``adapt`` 5-25 times
  slower (docs/performance.md, "adapt on hands written by others"; that measurement came
  first, so this default was set after seeing it).

Folds are stratified by shape; every known grasp is predicted by a model fitted without it,
and everything a way learns from the known grasps (the offset too) is learnt inside the fold.
With fewer than :data:`LOO_BELOW` grasps in all, the folds are leave-one-out. The way with the
highest held-out accuracy is kept (ties: the first in the order above, the simpler); its
accuracy comes with a 95% Wilson interval over the held-out answers, and a learning curve
(accuracy against grasps per shape, subsampled) says whether more grasps would help.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import UsageError

NEAREST_DESCRIPTOR = "signature+coupled-joints"
SHIFTED_CLASSIFIER = "svm"
KNOWN_WEIGHT = 5
"""How many times each known grasp is repeated beside the default's (shifted) training grasps."""
LOO_BELOW = 60
"""Known sets smaller than this are cross-validated leave-one-out; larger ones in
:data:`MAX_FOLDS` stratified folds (fewer where a shape has fewer grasps)."""
MAX_FOLDS = 10
CURVE_DRAWS = 5
"""Random draws of k grasps per shape per point of the learning curve."""
STILL_RISING = 0.02
"""A gain of at least this (2 points) from the curve's last step means more grasps would help."""
Z95 = 1.959963984540054

WAYS = ("default", "nearest-known", "default-shifted", "train-known", "calibrated-shape-fit")
WAY_TEXT = {
    "default": "the default identifier as shipped",
    "nearest-known": f"the nearest known grasp ({NEAREST_DESCRIPTOR}, knn, 1 neighbour)",
    "default-shifted": "the default's training grasps shifted to the hand, the known grasps "
    f"x{KNOWN_WEIGHT}, {SHIFTED_CLASSIFIER}",
    "train-known": "the default's method trained on --data with the known grasps added",
    "calibrated-shape-fit": "the shape fit with its coefficients calibrated to the hand on the "
    "known grasps",
}
CV_STRENGTHS = (1.0, 0.25)
"""The calibration's pulls tried inside adapt's cross-validation (``calibrate`` tries four)."""
CV_INNER_FOLDS = 2


def wilson(correct: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a proportion ``correct / n`` (95% by default)."""
    if n <= 0:
        return (0.0, 1.0)
    p = correct / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def check_known(records: Sequence, known_shapes: Sequence[str]) -> tuple[list, int]:
    """The labelled known grasps and how many unlabelled ones were left out; a UsageError
    where they cannot be cross-validated: none labelled, one shape only, a shape with fewer
    than 2 grasps, a shape name the package does not know (a typo)."""
    from ..realhand.names import UNKNOWN_SHAPE

    labelled = [r for r in records if r.shape and r.shape != UNKNOWN_SHAPE]
    skipped = len(records) - len(labelled)
    if not labelled:
        raise UsageError("--known holds no labelled grasps: label them when importing "
                         "(import --shape NAME, or --labels FILE.csv)")  # fmt: skip
    counts = Counter(str(r.shape) for r in labelled)
    unknown = sorted(set(counts) - set(known_shapes))
    if unknown:
        raise UsageError(f"--known labels grasps {unknown[0]!r}, not a shape tactile-bullet "
                         f"knows ({', '.join(known_shapes)})")  # fmt: skip
    if len(counts) < 2:
        raise UsageError(f"--known holds grasps of one shape only ({next(iter(counts))}): "
                         "give grasps of at least two")  # fmt: skip
    few = sorted(s for s, n in counts.items() if n < 2)
    if few:
        raise UsageError(f"--known holds {counts[few[0]]} grasp of {few[0]!r}: every shape "
                         "needs at least 2 (one to fit, one to check)")  # fmt: skip
    return labelled, skipped


def default_training(model) -> tuple[np.ndarray, np.ndarray]:
    """The default model's training features and labels: read from its fitted k-NN where it is
    one (it keeps its training grasps standardised, with their mean and scale), else from the
    features shipped beside the default (``default_training.npz``, sha256-checked). A
    UsageError where neither holds them."""
    est = model.estimator
    if not all(hasattr(est, a) for a in ("train_", "mean_", "scale_", "classes_", "y_index_")):
        from ..learn.default import default_model, default_training_set

        if model is not default_model():
            raise UsageError("the model keeps no training grasps (not a k-NN)")
        return default_training_set()  # shipped beside the default
    x = np.asarray(est.train_, dtype=float) * est.scale_ + est.mean_
    return x, np.asarray(est.classes_)[est.y_index_].astype(str)


def folds_of(y: np.ndarray, seed: int = 0) -> list[np.ndarray]:
    """Held-out index sets: leave-one-out below :data:`LOO_BELOW` grasps, else stratified
    folds (at most :data:`MAX_FOLDS`, at most the fewest grasps of a shape)."""
    if len(y) < LOO_BELOW:
        return [np.array([i]) for i in range(len(y))]
    from sklearn.model_selection import StratifiedKFold

    n = min(MAX_FOLDS, min(Counter(y.tolist()).values()))
    split = StratifiedKFold(n_splits=n, shuffle=True, random_state=seed)
    return [test for _, test in split.split(np.zeros(len(y)), y)]


@dataclass
class Way:
    """A candidate: ``predict(train_idx, test_idx) -> names`` fitted on the known grasps of
    ``train_idx`` only (``uses_known`` False: the known grasps are never read)."""

    name: str
    predict: Callable[[np.ndarray, np.ndarray], np.ndarray]
    uses_known: bool = True


def _fit_predict(classifier: str, x: np.ndarray, y: np.ndarray, test: np.ndarray,
                 params: dict | None = None) -> np.ndarray:  # fmt: skip
    from ..plugins import get_classifier

    est = get_classifier(classifier, **(params or {}))
    est.fit(x, y)
    return np.asarray(est.predict(test)).astype(str)


def shifted_set(xd, yd, xk, yk) -> tuple[np.ndarray, np.ndarray]:
    """The default's training features moved by the hand's mean offset (over the shapes both
    hold), with the known grasps repeated :data:`KNOWN_WEIGHT` times."""
    shared = sorted(set(yk.tolist()) & set(yd.tolist()))
    offset = np.zeros(xd.shape[1])
    if shared:
        offset = np.mean([xk[yk == s].mean(axis=0) - xd[yd == s].mean(axis=0) for s in shared],
                         axis=0)  # fmt: skip
    x = np.concatenate([xd + offset, np.repeat(xk, KNOWN_WEIGHT, axis=0)])
    y = np.concatenate([yd, np.repeat(yk, KNOWN_WEIGHT)])
    return x, y


def candidate_ways(
    known: Sequence, data: Sequence | None = None, calibrate: bool = False
) -> tuple[list[Way], dict]:
    """The ways that apply to these known grasps (and ``data``; ``calibrate``: the calibrated
    shape fit too), and why the others do not."""
    from ..learn.default import default_model
    from ..plugins import get_descriptor

    y = np.array([str(r.shape) for r in known])
    default = default_model()
    ways, skipped = [], {}
    answers = default.predict_records(list(known))
    ways.append(Way("default", lambda tr, te: answers[te], uses_known=False))

    xn = np.asarray(get_descriptor(NEAREST_DESCRIPTOR).transform(list(known)), dtype=float)
    ways.append(Way("nearest-known", lambda tr, te: _fit_predict(
        "knn", xn[tr], y[tr], xn[te], {"n_neighbors": 1})))  # fmt: skip

    extra = sorted(set(y.tolist()) - set(default.classes))
    try:
        xd, yd = default_training(default)
    except UsageError as exc:
        skipped["default-shifted"] = str(exc)
    else:
        xk = default.features(list(known))

        def shifted(tr, te):
            x, yy = shifted_set(xd, yd, xk[tr], y[tr])
            return _fit_predict(SHIFTED_CLASSIFIER, x, yy, xk[te])

        ways.append(Way("default-shifted", shifted))
    if extra:
        skipped["default"] = (f"it does not know {', '.join(extra)} (it names "
                              f"{', '.join(default.classes)})")  # fmt: skip
        ways = [w for w in ways if w.name != "default"]
    way = _calibrated_shape_fit_way(known, y) if calibrate else "not asked for (--calibrate)"
    if isinstance(way, str):
        skipped["calibrated-shape-fit"] = way
    else:
        ways.append(way)
    if data is None:
        skipped["train-known"] = "no --data (a simulated training set) given"
    else:
        desc = get_descriptor(default.descriptor, **default.descriptor_params)
        lacking = sorted(set(y.tolist()) - {str(r.shape) for r in data})
        if lacking:
            skipped["train-known"] = f"--data holds no {lacking[0]}"
        else:
            xs = np.asarray(desc.transform(list(data)), dtype=float)
            ys = np.array([str(r.shape) for r in data])
            xk2 = np.asarray(desc.transform(list(known)), dtype=float)
            ways.append(Way("train-known", lambda tr, te: _fit_predict(
                default.classifier, np.concatenate([xs, xk2[tr]]),
                np.concatenate([ys, y[tr]]), xk2[te], default.classifier_params)))  # fmt: skip
    return ways, skipped


def _known_fit_angles(known: Sequence) -> np.ndarray:
    """(n, 3, 4) J3, J2, J1 per long finger of each known grasp, read from the ``raw-joints``
    columns as the shape-fit classifier reads them."""
    from ..learn.shape_fit_vote import fci_columns
    from ..plugins import get_descriptor

    x = np.asarray(get_descriptor("raw-joints").transform(list(known)), dtype=float)
    return x[:, fci_columns(x.shape[1])]


def _calibrated_shape_fit_way(known: Sequence, y: np.ndarray) -> Way | str:
    """The calibrated shape fit as a way, or why it does not apply."""
    from ..perception.fit_batch import fit_names
    from ..perception.hand_fit import fit_hand
    from ..perception.shape_fit import fitted_shapes

    alien = sorted(set(y.tolist()) - set(fitted_shapes()))
    if alien:
        return f"the shape fit has no model of {alien[0]!r}"
    angles = _known_fit_angles(known)
    families = sorted(set(y.tolist()))

    def predict(tr: np.ndarray, te: np.ndarray) -> np.ndarray:
        cal = None
        if len(set(y[tr].tolist())) >= 2:
            cal = fit_hand(list(angles[tr]), list(y[tr]), strengths=CV_STRENGTHS,
                           folds=CV_INNER_FOLDS).calibration  # fmt: skip
        return np.array(fit_names(angles[te], families, cal))

    return Way("calibrated-shape-fit", predict)


def calibration_param(known: Sequence) -> dict:
    """The ``calibration`` parameter of a shape-fit model for the hand of ``known``: its
    coefficients fitted on every known grasp, as ``calibrate`` fits them."""
    from ..perception.hand_fit import fit_hand

    y = [str(r.shape) for r in known]
    cal = fit_hand(list(_known_fit_angles(known)), y).calibration
    return {**cal.to_dict(), "angles": cal.angles}


def cross_validate(way: Way, y: np.ndarray, folds: list[np.ndarray]) -> np.ndarray:
    """Each known grasp's answer from a model fitted without its fold."""
    answers = np.empty(len(y), dtype=object)
    everyone = np.arange(len(y))
    for test in folds:
        train = np.setdiff1d(everyone, test)
        answers[test] = way.predict(train, test)
    return answers.astype(str)


def learning_curve(way: Way, y: np.ndarray, seed: int = 0,
                   draws: int = CURVE_DRAWS) -> list[dict[str, Any]]:  # fmt: skip
    """Accuracy with k known grasps per shape (k from 1 to one less than the fewest of a
    shape, at most 5 points), each k over ``draws`` random subsets, the rest held out."""
    fewest = min(Counter(y.tolist()).values())
    if not way.uses_known or fewest < 2:
        return []
    ks = sorted({int(round(k)) for k in np.linspace(1, fewest - 1, min(5, fewest - 1))})
    rng = np.random.default_rng(seed)
    shapes = sorted(set(y.tolist()))
    curve = []
    for k in ks:
        scores = []
        for _ in range(draws):
            train = np.concatenate([rng.choice(np.flatnonzero(y == s), k, replace=False)
                                    for s in shapes])  # fmt: skip
            test = np.setdiff1d(np.arange(len(y)), train)
            scores.append(float(np.mean(way.predict(train, test) == y[test])))
        curve.append({"per_shape": k, "accuracy": float(np.mean(scores))})
    return curve


def advice(curve: list[dict[str, Any]], fewest: int) -> str:
    """One sentence on whether more known grasps per shape would help, from the curve."""
    if len(curve) < 2:
        return (f"too few grasps per shape ({fewest}) to draw a learning curve: record more "
                "(5 per shape gives one)")  # fmt: skip
    gain = curve[-1]["accuracy"] - curve[-2]["accuracy"]
    step = curve[-1]["per_shape"] - curve[-2]["per_shape"]
    per = gain / max(step, 1)
    if per >= STILL_RISING:
        more = max(2, fewest)
        return (f"still rising (+{100 * per:.1f} points per grasp per shape at "
                f"{curve[-1]['per_shape']}): about {more} more grasps per shape should help")
    return (f"flat (+{100 * per:.1f} points per grasp per shape at {curve[-1]['per_shape']}): "
            "more grasps per shape would add little")  # fmt: skip


def adapt(known: Sequence, data: Sequence | None = None, seed: int = 0,
          tick: Callable[[str, int, int], None] | None = None,
          calibrate: bool = False) -> dict[str, Any]:  # fmt: skip
    """Score every candidate way on the known grasps, keep the best; the doc :func:`build`
    and the command read (``ways``: each way's held-out accuracy, interval and answers)."""
    y = np.array([str(r.shape) for r in known])
    folds = folds_of(y, seed)
    ways, skipped = candidate_ways(known, data, calibrate)
    rows = []
    for i, way in enumerate(ways):
        if tick:
            tick("adapt: ways cross-validated", i, len(ways))
        answers = cross_validate(way, y, folds)
        correct = int(np.sum(answers == y))
        lo, hi = wilson(correct, len(y))
        rows.append({"way": way.name, "text": WAY_TEXT[way.name], "accuracy": correct / len(y),
                     "correct": correct, "held_out": len(y), "interval": [lo, hi],
                     "per_shape": {s: float(np.mean(answers[y == s] == s))
                                   for s in sorted(set(y.tolist()))}})  # fmt: skip
    if tick:
        tick("adapt: ways cross-validated", len(ways), len(ways))
    best = max(range(len(rows)), key=lambda i: (rows[i]["accuracy"], -i))
    chosen = ways[best]
    curve = learning_curve(chosen, y, seed)
    if not curve:  # the default needs no known grasps: the curve of the best way that does
        learner = next((w for w, r in sorted(zip(ways, rows, strict=True),
                                             key=lambda p: -p[1]["accuracy"])
                        if w.uses_known), None)  # fmt: skip
        curve_way = learner.name if learner else None
        curve = learning_curve(learner, y, seed) if learner else []
    else:
        curve_way = chosen.name
    fewest = min(Counter(y.tolist()).values())
    return {
        "known_grasps": len(y),
        "shapes": dict(sorted(Counter(y.tolist()).items())),
        "folds": "leave-one-out" if len(folds) == len(y) else f"{len(folds)} stratified folds",
        "ways": rows,
        "skipped": skipped,
        "chosen": rows[best]["way"],
        "accuracy": rows[best]["accuracy"],
        "interval": rows[best]["interval"],
        "curve": curve,
        "curve_way": curve_way,
        "advice": advice(curve, fewest),
    }


def build(way: str, known: Sequence, data: Sequence | None = None):
    """The chosen way fitted on every known grasp: one model ``identify --model`` reads."""
    from ..learn.default import default_model
    from ..learn.doubt import KnownGrasps, model_doubt
    from ..learn.models import Model
    from .training import _novelty, train

    if way == "default":
        base = default_model()
        return Model(base.descriptor, dict(base.descriptor_params), base.classifier,
                     dict(base.classifier_params), base.estimator, info=dict(base.info),
                     known=base.known, novelty=base.novelty, axis=base.axis)  # fmt: skip
    if way == "nearest-known":
        return train(list(known), NEAREST_DESCRIPTOR, "knn", {"n_neighbors": 1})
    if way == "calibrated-shape-fit":
        return train(list(known), "raw-joints", "shape-fit",
                     {"calibration": calibration_param(known)})  # fmt: skip
    if way == "train-known":
        from ..learn.trainings import with_known

        base = default_model()
        fit_on = with_known(list(data), list(known), "clean")
        return train(fit_on, base.descriptor, base.classifier, base.classifier_params or None,
                     base.descriptor_params, known=list(known))  # fmt: skip
    if way != "default-shifted":
        raise UsageError(f"unknown way {way!r} (ways: {', '.join(WAYS)})")
    from ..plugins import get_classifier

    base = default_model()
    xd, yd = default_training(base)
    xk = base.features(list(known))
    yk = np.array([str(r.shape) for r in known])
    x, y = shifted_set(xd, yd, xk, yk)
    est = get_classifier(SHIFTED_CLASSIFIER)
    est.fit(x, y)
    reference = KnownGrasps.from_records(list(known))
    make = lambda: get_classifier(SHIFTED_CLASSIFIER)  # noqa: E731
    info = {"doubt": model_doubt(make, x, y, None, SHIFTED_CLASSIFIER, reference)}
    novelty = _novelty(x, y)
    if novelty is not None:
        info["novelty"] = novelty.summary()
    # the axis thresholds are the objects' geometry on each engine: a hand's shift keeps them
    return Model(base.descriptor, dict(base.descriptor_params), SHIFTED_CLASSIFIER, {}, est,
                 info=info, known=reference, novelty=novelty, axis=base.axis)  # fmt: skip
