"""Answers that admit doubt: the margin between the two best shapes, and when it is too small.

A classifier's top probability says little on its own: on grasps from another simulator wrong
answers came at probability 0.9-1.0. What is compared here is the *margin*, the decided
shape's probability minus the best other shape's. Where the margin is below the model's
calibrated threshold the answer is *ambiguous*: the best guess is still given, with the runner-up
named beside it.

The threshold is calibrated per model on held-out training data (:func:`calibrate_margin`):
every training grasp is predicted by a copy of the classifier fitted on the other folds, and the
threshold is set so that at most ``FALSE_ALARM`` of those held-out *right* answers fall below it
(the largest threshold that keeps that promise, so as many wrong answers as possible are
flagged). It is stored in the model file's ``info["doubt"]``; a model written before it existed
loads without one and then flags nothing (its answers still carry their margin).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

FALSE_ALARM = 0.05
"""Share of held-out right answers the calibrated threshold may flag."""
FOLDS = 3
"""Held-out folds of the calibration (each grasp is predicted once, by a fit without it)."""


def margins(proba: np.ndarray, decided: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(margin, runner-up column) per row of ``proba`` (n, n_classes) given the column of the
    decided shape: p[decided] - max of the others. Negative where the estimator's decision is
    not its probabilities' argmax (an SVM with Platt scaling can do that): surely doubtful."""
    proba = np.asarray(proba, dtype=float)
    decided = np.asarray(decided, dtype=int)
    if proba.shape[1] < 2:
        return np.ones(len(proba)), decided.copy()
    rows = np.arange(len(proba))
    others = proba.copy()
    others[rows, decided] = -np.inf
    second = np.argmax(others, axis=1)
    return proba[rows, decided] - proba[rows, second], second


def threshold_for(right_margins: Sequence[float], false_alarm: float = FALSE_ALARM) -> float:
    """The largest threshold t with at most ``false_alarm`` of ``right_margins`` below t
    (an answer is flagged when its margin < t); 0 (nothing flagged) without right answers."""
    values = np.sort(np.asarray(right_margins, dtype=float))
    if values.size == 0:
        return 0.0
    k = int(np.floor(false_alarm * values.size))
    return float(values[min(k, values.size - 1)])


def flagged(margin: np.ndarray | float, threshold: float | None) -> np.ndarray:
    """Which answers are ambiguous (margin below the threshold); none without a threshold."""
    m = np.asarray(margin, dtype=float)
    if threshold is None:
        return np.zeros(m.shape, dtype=bool)
    return m < float(threshold)


def flag_shares(is_flagged: np.ndarray, correct: np.ndarray) -> dict[str, float | None]:
    """Share of all answers, of right answers and of wrong answers flagged (None: no such
    answers): the figures a report gives for its doubt."""
    is_flagged = np.asarray(is_flagged, dtype=bool)
    correct = np.asarray(correct, dtype=bool)

    def share(mask: np.ndarray) -> float | None:
        return float(is_flagged[mask].mean()) if mask.any() else None

    return {
        "flagged": share(np.ones_like(correct)),
        "right_flagged": share(correct),
        "wrong_flagged": share(~correct),
    }


def held_out_margins(
    make: Callable[[], Any], x: np.ndarray, y: np.ndarray, folds: int = FOLDS, seed: int = 0
) -> tuple[np.ndarray, np.ndarray] | str:
    """(margins, correct) of every row predicted by a fresh estimator (``make()``) fitted on the
    other folds, or the reason none can be had (too few grasps of a shape)."""
    from sklearn.model_selection import StratifiedKFold

    y = np.asarray(y).astype(str)
    _, counts = np.unique(y, return_counts=True)
    k = min(int(folds), int(counts.min()))
    if k < 2:
        return f"a shape has {int(counts.min())} grasp(s): none can be held out"
    out_margin = np.empty(len(y))
    out_right = np.empty(len(y), dtype=bool)
    splitter = StratifiedKFold(n_splits=k, shuffle=True, random_state=seed)
    for train_idx, test_idx in splitter.split(x, y):
        if len(np.unique(y[train_idx])) < 2:
            return "a fold holds a single shape"
        try:
            est = make().fit(x[train_idx], y[train_idx])
            names = np.asarray(est.predict(x[test_idx])).astype(str)
            proba = np.asarray(est.predict_proba(x[test_idx]), dtype=float)
        except (ValueError, AttributeError, NotImplementedError) as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            return f"a held-out fold could not be fitted ({first})"
        classes = [str(c) for c in est.classes_]
        decided = np.array([classes.index(n) for n in names])
        out_margin[test_idx] = margins(proba, decided)[0]
        out_right[test_idx] = names == y[test_idx]
    return out_margin, out_right


def calibrate_margin(
    make: Callable[[], Any],
    x: np.ndarray,
    y: np.ndarray,
    folds: int = FOLDS,
    false_alarm: float = FALSE_ALARM,
    seed: int = 0,
) -> dict[str, Any]:
    """The model file's ``info["doubt"]``: ``margin`` (the threshold, None when it could not
    be calibrated, with ``reason``), the held-out figures it was set on, and how."""
    found = held_out_margins(make, x, y, folds, seed)
    doc: dict[str, Any] = {"false_alarm": float(false_alarm), "folds": int(folds)}
    if isinstance(found, str):
        return {**doc, "margin": None, "reason": found}
    m, right = found
    threshold = threshold_for(m[right], false_alarm)
    shares = flag_shares(flagged(m, threshold), right)
    return {
        **doc,
        "margin": threshold,
        "held_out": int(len(m)),
        "held_out_wrong": int((~right).sum()),
        "right_flagged": shares["right_flagged"],
        "wrong_flagged": shares["wrong_flagged"],
    }


def model_threshold(info: dict) -> float | None:
    """The calibrated threshold in a model's ``info``, None where there is none (an older
    model file, or one whose data held too few grasps to hold any out)."""
    doubt = info.get("doubt") if isinstance(info, dict) else None
    if not isinstance(doubt, dict):
        return None
    value = doubt.get("margin")
    if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
        return None
    return float(value)


def answer_doubt(
    classes: Sequence[str], shape: str, proba: np.ndarray | None, threshold: float | None
) -> dict[str, Any]:
    """``{"margin", "ambiguous"}`` of one answer: ``ambiguous`` is ``[shape, runner-up]`` when
    the margin is below the threshold, else None; without probabilities the margin is None."""
    if proba is None or len(classes) < 2:
        return {"margin": None, "ambiguous": None}
    classes = [str(c) for c in classes]
    decided = classes.index(shape)
    m, second = margins(np.asarray(proba, dtype=float)[None, :], np.array([decided]))
    margin = float(m[0])
    doubtful = bool(flagged(margin, threshold))
    return {
        "margin": margin,
        "ambiguous": [shape, classes[int(second[0])]] if doubtful else None,
    }
