"""The training-free shape fit's held-out margins, read from its grid where the grid decides.

The shape fit learns nothing, so calibrating its doubt (:func:`.doubt.calibrate_margin`) is one
fit per training grasp, which made training it about twice an svm's on the modified preset
(issue 30's target: 1.5x). Most of those fits need not finish: where the grid stage alone
decides the family (:func:`~tactile_bullet.perception.shape_fit.name_or_fit`), every other
family scores more than ``REFINE_MARGIN`` above it whatever the search finds, so the answer's
margin is at least :func:`margin_floor` (within 1e-10 of 1 at the default temperature). Such
a grasp keeps that floor in place of its margin. The threshold reads the lowest held-out right
margins; only where it reaches a floor are the floored grasps fitted whole. The threshold and
the shares flagged are therefore the ones whole fits give (``tests/test_fit_margins.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np


def stratified_sample(
    y: np.ndarray, n: int, seed: int, groups: np.ndarray | None = None
) -> np.ndarray:
    """Sorted indices of about ``n`` rows of ``y``, each label in proportion (at least 2 of
    each, so that every shape can still be held out); ``groups``: copies of one grasp are
    drawn, or left, together."""
    from sklearn.model_selection import train_test_split

    ids = np.arange(len(y)) if groups is None else np.asarray(groups)
    first = np.unique(ids, return_index=True)[1]  # one row per grasp
    labels, counts = np.unique(y[first], return_counts=True)
    want = int(round(n * len(first) / len(y)))
    if want >= len(first) or want < 2 * len(labels) or counts.min() < 2:
        return np.arange(len(y))
    chosen, _ = train_test_split(first, train_size=want, stratify=y[first], random_state=seed)
    return np.flatnonzero(np.isin(ids, ids[chosen]))


def is_training_free(estimator: Any) -> bool:
    """Whether ``estimator`` is the shape-fit classifier, whose margins this module reads."""
    from .classifiers.shape_fit import ShapeFitClassifier

    return isinstance(estimator, ShapeFitClassifier)


def margin_floor(classes: int, temperature: float) -> float:
    """The least margin of an answer the grid decides: every other family's score at least
    ``REFINE_MARGIN`` (g) above the best, p ~ exp(-score / T), so the best family's
    probability is at least 1 / (1 + (k - 1) e^(-g/T)) and the runner-up's at most e^(-g/T)
    times it. A hair below that value, so that rounding never puts a margin under it."""
    from ..perception.shape_fit import REFINE_MARGIN

    e = math.exp(-REFINE_MARGIN / float(temperature))
    return (1.0 - e) / (1.0 + (classes - 1) * e) - 1e-9


def read_folds(
    folds: Sequence[tuple[Any, np.ndarray]], x: np.ndarray, y: np.ndarray,
    threshold: Callable[[np.ndarray], float],
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(margins, correct) of every row of ``folds`` ((a fitted shape-fit classifier, its
    held-out rows) each), as :func:`.doubt.held_out_margins` gives them, a floor standing in for
    the margins the grid decides that lie above the ``threshold`` read from the right ones
    (:func:`.doubt.threshold_for`)."""
    margin, right = np.full(len(y), np.nan), np.zeros(len(y), dtype=bool)
    floored = np.zeros(len(y), dtype=bool)
    shared: dict[tuple[str, ...], tuple[Any, list[np.ndarray]]] = {}
    for est, rows in folds:  # folds with the same classes read in one batch
        shared.setdefault(tuple(str(c) for c in est.classes_), (est, []))[1].append(rows)
    batches = [(est, np.concatenate(parts)) for est, parts in shared.values()]
    for est, rows in batches:
        _read(est, rows, x, y, margin, right, floored, whole=False)
    if floored.any() and right.any() and \
            (margin[floored] <= threshold(margin[right])).any():  # fmt: skip
        for est, rows in batches:
            _read(est, rows[floored[rows]], x, y, margin, right, floored, whole=True)
    return margin, right


def _read(est, rows, x, y, margin, right, floored, whole: bool) -> None:
    """Margins of ``rows`` by ``est``: whole fits, or the grid's family where it decides."""
    from ..perception.fit_batch import fit_answers, fit_many
    from .shape_fit_vote import fci_columns, probabilities

    if len(rows) == 0:
        return
    classes = [str(c) for c in est.classes_]
    cols = fci_columns(x.shape[1])
    angles = [x[i][cols] for i in rows]
    found = (fit_many if whole else fit_answers)(angles, classes, est.calibration_,
                                                 "doubt calibration fits")  # fmt: skip
    floor = margin_floor(len(classes), est.temperature)
    for i, fit in zip(rows, found, strict=True):
        if isinstance(fit, str):  # the grid decided: its margin is at least the floor
            name, margin[i], floored[i] = fit, floor, True
        else:
            scores = np.array([[fit.fits[c].score for c in classes]])
            name = classes[int(np.argmin(scores[0]))]  # as predict names it: the likeliest
            second, best = np.sort(probabilities(scores, est.temperature)[0])[-2:]
            margin[i], floored[i] = best - second, False
        right[i] = name == str(y[i])
