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

The margin alone misses the errors that matter most: an SVM on signatures, or any model on
grasps from a shifted simulator, is wrong *with* a large margin (benchmarks/doubt_report.py: 0 of 21
wrong answers flagged). So a model whose classes the training-free shape fit can model is also
*cross-checked*: the shape fit (``perception/shape_fit.py``, which learns nothing from the
training data and reads the absolute joint angles) names the grasp too, and an answer it
contradicts is ambiguous between the two names. The margin threshold then gets what the
cross-check leaves of the ``FALSE_ALARM`` budget on the held-out right answers (nothing, where the
shape fit alone contradicts more of them: ``info["doubt"]["right_flagged"]`` then says by how
much the promise is missed on the training grasps).

A model fitted with grasps of the user's own hand (``train --known``) is cross-checked by those
grasps instead (:class:`KnownGrasps`): the nearest known grasp (in ``KNOWN_DESCRIPTOR``'s
features, each scaled by its spread over the known grasps) names the shape too. The shape fit
assumes our hand's geometry and coupling and reads an unfamiliar hand poorly (58-62% on the
blind hand of ``docs/independent_hand.md``, where it contradicted 28-39% of right answers);
the known grasps are that hand. The margin is then calibrated on the training folds
alone, with the whole ``FALSE_ALARM`` budget.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from .known_grasps import KNOWN_DESCRIPTOR, MAX_KNOWN_GRASPS, KnownGrasps  # noqa: F401 - re-exported

FALSE_ALARM = 0.05
"""Share of held-out right answers the calibrated threshold may flag."""
FOLDS = 3
"""Held-out folds of the calibration (each grasp is predicted once, by a fit without it)."""
CROSS_CHECK = "shape-fit"
"""The independent second opinion (the training-free shape fit)."""
CROSS_CHECK_SAMPLES = 100
"""Training grasps the cross-check reads while calibrating (a shape fit takes ~20-60 ms)."""
TRAINING_FREE_SAMPLES = 200
"""Training grasps the shape fit's own margin is calibrated on, drawn per shape in proportion:
it learns nothing from them, so its held-out margins on a sample are a sample of its margins on
all, and the 5% threshold read from ~190 right answers is off by ~1.6 points of false alarms
(one standard error), where fitting every grasp of the thesis preset made its training several
times an svm's (docs/performance.md, "Shape fits on every core")."""
KNOWN_CHECK = "known-grasps"
"""The second opinion of a model fitted with the user's known grasps (``train --known``)."""
SECOND_MODEL = "second-model"
"""The second opinion of a model carrying a second classifier (the shipped default's:
``learn/second_opinion.py``)."""


def cross_check_applies(classes: Sequence[str], classifier: str) -> bool:
    """Whether the shape fit can second a model: every class one of its families, and the
    model not the shape fit itself."""
    from ..perception.shape_fit import fitted_shapes

    known = set(fitted_shapes())
    return classifier != CROSS_CHECK and all(str(c) in known for c in classes)


CROSS_CHECK_TOLERANCE = 0.0
"""Fit score within which of the shape fit's best a family still counts as the fit's answer:
a model's answer the fit scores that close to its own best is not contradicted. The scores
are penalised soft-L1 sums of squared residuals in units of each angle's spread, and the
shape-fit classifier's probabilities go as exp(-score), so 1.0 would be two families within a
factor e. Zero: only the fit's best counts. A tolerance of 1.0 was declared before the
sixteenth replicate and reverted on it: it forgave many right answers but more wrong ones than
the declared limit (docs/robustness.md); ``benchmarks/cross_check_tolerance.py`` scores a
tolerance beside none."""

OWN_HAND_COEFFICIENTS = True
"""The cross-check reads a grasp of our own MuJoCo hand with that hand's coefficients
(``realhand.hand_calibration.record_calibration``), not Bullet's; judged on the tenth replicate
(docs/robustness.md). False: every grasp with the coefficients in force, as before."""


def cross_check_names(records: Sequence, classes: Sequence[str]) -> np.ndarray:
    """The shape fit's answer among ``classes`` for each record ('' where it cannot read one)
    (the first of :func:`cross_check_accepts`)."""
    found = [a[0] if a else "" for a in cross_check_accepts(records, classes)]
    return np.array(found, dtype=object).astype(str)


def cross_check_accepts(records: Sequence, classes: Sequence[str]) -> list[tuple[str, ...]]:
    """The families among ``classes`` the shape fit accepts for each record: its answer first,
    then any it scores within :data:`CROSS_CHECK_TOLERANCE` of it (``()`` where it cannot read
    one). Each record is read as the coefficients in force were fitted
    (:func:`.robust.angles_for_shape_fit`), a grasp of our own MuJoCo hand with that hand's
    coefficients where no hand calibration is in force (:data:`OWN_HAND_COEFFICIENTS`)."""
    from ..realhand.hand_calibration import record_calibration

    groups: dict[int, tuple] = {}  # one batch of fits per set of coefficients
    for i, rec in enumerate(records):
        cal = record_calibration(rec) if OWN_HAND_COEFFICIENTS else None
        groups.setdefault(id(cal), (cal, []))[1].append(i)
    out: list[tuple[str, ...]] = [()] * len(records)
    for cal, index in groups.values():
        for i, found in zip(index, _cross_check_batch([records[i] for i in index], classes, cal),
                            strict=True):  # fmt: skip
            out[i] = found
    return out


def seconding(names: Sequence[str], accepted: Sequence[tuple[str, ...]]) -> list[str]:
    """The second opinion each answer gets: the answer itself where the shape fit accepts it
    (:func:`cross_check_accepts`), else the fit's own answer ('' where it has none)."""
    return [str(n) if str(n) in a else (a[0] if a else "")
            for n, a in zip(names, accepted, strict=True)]  # fmt: skip


def _accepted(found) -> tuple[str, ...]:
    """The families one fit accepts: a family the grid alone decided (every other scored more
    than the search's refining margin above it, far beyond the tolerance), or the whole fit's
    best and the families within :data:`CROSS_CHECK_TOLERANCE` of its score."""
    if isinstance(found, str):
        return (found,)
    best = found.fits[found.shape].score
    near = sorted((f.score, name) for name, f in found.fits.items()
                  if name != found.shape and f.score <= best + CROSS_CHECK_TOLERANCE)  # fmt: skip
    return (found.shape, *(name for _, name in near))


def _cross_check_batch(records: Sequence, classes: Sequence[str], calibration) -> list:
    """:func:`cross_check_accepts` of records read with one set of coefficients (None: those
    in force)."""
    from ..errors import UsageError
    from ..perception.fit_batch import fit_answers
    from ..perception.shape_model import use_own
    from .robust import angles_for_shape_fit

    families = [str(c) for c in classes]
    angles, readable = [], []
    with use_own(calibration):
        for i, rec in enumerate(records):
            try:
                angles.append(angles_for_shape_fit(rec))
                readable.append(i)
            except UsageError:  # no angles to read: no second opinion
                pass
        # each grasp's answer is kept: asked again (another fold), it is not redone; a fit's
        # sizes are computed only where the grid leaves the family open
        found = fit_answers(angles, families, desc="shape fit (second opinion)")
    out: list[tuple[str, ...]] = [()] * len(records)
    for i, fit in zip(readable, found, strict=True):
        out[i] = _accepted(fit)
    return out


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
    make: Callable[[], Any], x: np.ndarray, y: np.ndarray, folds: int = FOLDS, seed: int = 0,
    groups: np.ndarray | None = None, false_alarm: float | None = None,
) -> tuple[np.ndarray, np.ndarray] | str:
    """(margins, correct) of every row predicted by a fresh estimator (``make()``) fitted on the
    other folds, or the reason none can be had (too few grasps of a shape). ``groups``: rows
    that are copies of one grasp (noise-aware training) are held out together. With the
    ``false_alarm`` share the threshold is for, the shape fit's margins far above it are read
    from its grid (:mod:`.fit_margins`)."""
    from sklearn.model_selection import StratifiedKFold

    from .novelty import group_split

    y = np.asarray(y).astype(str)
    _, counts = np.unique(y, return_counts=True)
    k = min(int(folds), int(counts.min()))
    if k < 2:
        return f"a shape has {int(counts.min())} grasp(s): none can be held out"
    out_margin = np.empty(len(y))
    out_right = np.empty(len(y), dtype=bool)
    parts = group_split(y, groups, k, seed)
    if parts is None:
        parts = list(StratifiedKFold(n_splits=k, shuffle=True, random_state=seed).split(x, y))
    k = len(parts)
    from ..console import tick
    from .fit_margins import is_training_free, read_folds

    fits = []  # the shape fit's folds, read together after the loop
    for fold, (train_idx, test_idx) in enumerate(parts):
        tick("doubt calibration folds", fold, k)
        if len(np.unique(y[train_idx])) < 2:
            return "a fold holds a single shape"
        try:
            est = make().fit(x[train_idx], y[train_idx])
            if false_alarm is not None and is_training_free(est):
                fits.append((est, test_idx))
                continue
            names = np.asarray(est.predict(x[test_idx])).astype(str)
            proba = np.asarray(est.predict_proba(x[test_idx]), dtype=float)
        except (ValueError, AttributeError, NotImplementedError) as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            return f"a held-out fold could not be fitted ({first})"
        classes = [str(c) for c in est.classes_]
        decided = np.array([classes.index(n) for n in names])
        out_margin[test_idx] = margins(proba, decided)[0]
        out_right[test_idx] = names == y[test_idx]
    if fits:
        return read_folds(fits, x, y, lambda right: threshold_for(right, false_alarm))
    return out_margin, out_right


def calibrate_margin(
    make: Callable[[], Any],
    x: np.ndarray,
    y: np.ndarray,
    folds: int = FOLDS,
    false_alarm: float = FALSE_ALARM,
    seed: int = 0,
    records: Sequence | None = None,
    classifier: str = "",
    accepts: Callable[[Sequence, Sequence[str]], list] | None = None,
    groups: np.ndarray | None = None,
) -> dict[str, Any]:
    """The model file's ``info["doubt"]``: ``margin`` (the threshold, None when it could not
    be calibrated, with ``reason``), ``cross_check`` (``"shape-fit"`` or None: given the
    training ``records`` and a model the shape fit can second), the held-out figures it was
    set on, and how. ``accepts(records, classes)`` reads the families the shape fit accepts
    (default :func:`cross_check_accepts`; a caller that has read them already passes its
    cache)."""
    doc: dict[str, Any] = {"false_alarm": float(false_alarm), "folds": int(folds),
                           "cross_check": None}  # fmt: skip
    if classifier == CROSS_CHECK and len(y) > TRAINING_FREE_SAMPLES:
        from .fit_margins import stratified_sample

        keep = stratified_sample(np.asarray(y).astype(str), TRAINING_FREE_SAMPLES, seed, groups)
        doc["sampled_from"] = int(len(y))
        x, y = np.asarray(x)[keep], np.asarray(y)[keep]
        records = None if records is None else [records[i] for i in keep]
        groups = None if groups is None else np.asarray(groups)[keep]
    found = held_out_margins(make, x, y, folds, seed, groups, false_alarm)
    if isinstance(found, str):
        return {**doc, "margin": None, "reason": found}
    m, right = found
    y = np.asarray(y).astype(str)
    keep = np.arange(len(y))
    seconded = np.zeros(len(y), dtype=bool)
    if records is not None and cross_check_applies(sorted(set(y)), classifier):
        if len(keep) > CROSS_CHECK_SAMPLES:
            keep = np.sort(np.random.default_rng(seed).choice(len(y), CROSS_CHECK_SAMPLES, False))
        found = (accepts or cross_check_accepts)([records[i] for i in keep], sorted(set(y)))
        # a right held-out answer is the true label: the cross-check contradicts it where it
        # does not accept it (or reads no shape)
        other = np.array(seconding(y[keep], found), dtype=object).astype(str)
        seconded[keep] = (other != y[keep]) & right[keep]
        doc["cross_check"] = CROSS_CHECK
    m, right, seconded = m[keep], right[keep], seconded[keep]
    allowed = int(np.floor(false_alarm * right.sum()))
    contradicted = int(seconded.sum())
    if doc["cross_check"] is not None:
        doc["cross_check_contradicts"] = contradicted / max(1, int(right.sum()))
    # the margin alone gets what the cross-check leaves of the budget (none where the shape
    # fit alone contradicts more held-out right answers than the budget: it is kept anyway,
    # since it is what catches confident wrong answers; docs/doubt.md gives both figures)
    budget = allowed - contradicted
    pool = np.sort(m[right & ~seconded])
    threshold = -1.0 if budget < 0 or pool.size == 0 else float(pool[min(budget, pool.size - 1)])
    shares = flag_shares(flagged(m, threshold) | seconded, right)
    return {
        **doc,
        "margin": threshold,
        "held_out": int(len(m)),
        "held_out_wrong": int((~right).sum()),
        "right_flagged": shares["right_flagged"],
        "wrong_flagged": shares["wrong_flagged"] if doc["cross_check"] is None else None,
    }


def model_doubt(
    make: Callable[[], Any], x: np.ndarray, y: np.ndarray, records: Sequence | None,
    classifier: str, known: KnownGrasps | None = None, groups: np.ndarray | None = None,
) -> dict[str, Any]:  # fmt: skip
    """A trained model's ``info["doubt"]``: the margin calibrated on held-out folds of its
    training features ``x`` (``groups``: copies of one grasp held out together), seconded by
    the shape fit (read on ``records``) or, for a model fitted with the user's ``known``
    grasps, by them (:func:`with_known_check`)."""
    if known is not None:
        return with_known_check(calibrate_margin(make, x, y, groups=groups), known)
    return calibrate_margin(make, x, y, records=records, classifier=classifier, groups=groups)


def with_known_check(calibration: dict[str, Any], known: KnownGrasps) -> dict[str, Any]:
    """A margin calibration (made without the shape fit) seconded by the known grasps: the
    model file's ``info["doubt"]`` for ``train --known``."""
    return {
        **calibration,
        "cross_check": KNOWN_CHECK,
        "wrong_flagged": None,  # the held-out folds say nothing of the check on the user's hand
        "known": {
            "grasps": int(len(known.labels)),
            "descriptor": known.descriptor,
            "self_agreement": known.self_agreement(),
        },  # fmt: skip
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
    classes: Sequence[str],
    shape: str,
    proba: np.ndarray | None,
    threshold: float | None,
    second_opinion: str | None = None,
    novelty: float | None = None,
    novelty_threshold: float | None = None,
    contacts: Any = None,
    renamed_from: str | None = None,
) -> dict[str, Any]:
    """:func:`no_doubt`'s fields of one answer:
    ``ambiguous`` is ``[shape, runner-up]`` when the margin is below the threshold, else
    ``[shape, second_opinion]`` when the cross-check names another shape, else
    ``[shape, renamed_from]`` when the contacts overruled the classifier, else None; without
    probabilities the margin is None. ``cross_check`` is the second opinion (None where none
    was asked). ``unknown`` is True where the grasp's ``novelty`` (its distance from the
    model's training grasps, :mod:`.novelty`) is above the model's ``novelty_threshold``, or
    where the grasp's ``contacts`` (a :class:`~tactile_bullet.perception.contact_check.Verdict`)
    fit no solid of revolution, or no profile of the named family: no family the model knows
    explains it, and ``shape`` is only the best guess; ``unknown_why`` says which (None where
    known). ``renamed_from``: the classifier's own answer where the grasp's contacts named
    ``shape`` instead (a torus read as a sphere: ``Model.answers``)."""
    opinion = str(second_opinion) if second_opinion else None  # plain str, never numpy's
    out = no_doubt() | {
        "cross_check": opinion, "novelty": novelty,
        "axis_residual_mm": _mm(getattr(contacts, "axis_residual", None)),
        "profile_residual_mm": _mm(getattr(contacts, "profile_residual", None)),
        "renamed_from": renamed_from,
    }  # fmt: skip
    classes = [str(c) for c in classes]
    if proba is not None and len(classes) >= 2:
        decided = classes.index(shape)
        m, second = margins(np.asarray(proba, dtype=float)[None, :], np.array([decided]))
        out["margin"] = float(m[0])
        if bool(flagged(out["margin"], threshold)):
            out["ambiguous"] = [shape, classes[int(second[0])]]
    if out["ambiguous"] is None and opinion is not None and opinion != shape:
        out["ambiguous"] = [shape, opinion]
    if out["ambiguous"] is None and renamed_from is not None and renamed_from != shape:
        # the contacts overruled the classifier, whose probabilities stand: never sure
        out["ambiguous"] = [shape, renamed_from]
    why = getattr(contacts, "unknown_why", None)
    if novelty is not None and novelty_threshold is not None and novelty > novelty_threshold:
        out["unknown"], out["unknown_why"] = True, UNLIKE_TRAINING
    elif why is not None:
        out["unknown"] = True
        out["unknown_why"] = NOT_REVOLUTION if why == "axis" else NOT_PROFILE
    return out


def no_doubt() -> dict[str, Any]:
    """The doubt fields of an answer with nothing to doubt (no answer yet, or none asked):
    every one an answer carries, each empty, so every answer has the same keys."""
    return {"margin": None, "ambiguous": None, "cross_check": None, "unknown": False,
            "novelty": None, "unknown_why": None, "axis_residual_mm": None,
            "profile_residual_mm": None, "renamed_from": None}  # fmt: skip


def _mm(metres: float | None) -> float | None:
    return None if metres is None else round(1000.0 * float(metres), 3)


UNLIKE_TRAINING = "unlike every grasp the model learnt"
"""``unknown_why`` of the novelty rule (:mod:`.novelty`)."""
NOT_REVOLUTION = "its contacts fit no solid of revolution"
"""``unknown_why`` of the axis rule (:mod:`tactile_bullet.perception.revolution`)."""
NOT_PROFILE = "its contacts fit no profile of the family"
"""``unknown_why`` of the profile rule (:mod:`tactile_bullet.perception.profile_fit`)."""


BATCH_WARNING_SHARE = 0.25
"""Share of a batch's answers flagged above which the batch is warned about (at least
``BATCH_WARNING_MIN`` answers): on our own hand's held-out grasps, shifted simulators
included, 0-17% are flagged (docs/doubt.md); a quarter means the model, or its second
opinion, does not read this hand."""
BATCH_WARNING_MIN = 10


def batch_warning(flagged: int, answers: int) -> str | None:
    """One line for a batch of answers (a recording, an evaluation) of which ``flagged`` are
    ambiguous, when so many are that the hand itself is the doubt; None otherwise."""
    if answers < BATCH_WARNING_MIN or flagged <= BATCH_WARNING_SHARE * answers:
        return None
    return (
        f"{flagged} of {answers} answers are ambiguous: the model or its second opinion reads "
        "these grasps poorly. Another hand's grasps: fit the model to that hand with a few "
        "known grasps (adapt, train --known; docs/real_hand.md); grasps like the model's own "
        "training grasps: train it on more of them"
    )


def cross_flags(names, accepted: Sequence[tuple[str, ...]]) -> np.ndarray:
    """Which answers the cross-check flags (batched :func:`answer_doubt`'s second rule), from
    the families the shape fit accepts for each (:func:`cross_check_accepts`)."""
    seconds = np.array(seconding([str(n) for n in names], accepted), dtype=object).astype(str)
    return (seconds != "") & (seconds != np.asarray(names).astype(str))


def model_cross_check(info: dict) -> bool:
    """Whether a model's calibration asked for the shape fit's second opinion."""
    doubt = info.get("doubt") if isinstance(info, dict) else None
    return isinstance(doubt, dict) and doubt.get("cross_check") == CROSS_CHECK


def second_opinion(model) -> str | None:
    """Which second opinion a model's answers get: ``KNOWN_CHECK`` (it holds known grasps),
    ``SECOND_MODEL`` (it carries a second classifier), ``CROSS_CHECK`` (its calibration asked
    for the shape fit) or None."""
    if getattr(model, "known", None) is not None:
        return KNOWN_CHECK
    if getattr(model, "second", None) is not None:
        return SECOND_MODEL
    return CROSS_CHECK if model_cross_check(model.info) else None


def doubts(
    model, records: Sequence, names: Sequence[str], proba: np.ndarray | None,
    cross_check: bool = True, features: np.ndarray | None = None,
    renamed_from: Sequence[str | None] | None = None,
) -> list:  # fmt: skip
    """:func:`answer_doubt` of each of a model's answers, with its second opinion
    (:func:`second_opinion`; unless ``cross_check`` is False: the margin only, sooner).
    ``features``: the records' features where the caller has them (else computed again);
    ``renamed_from``: ``Model.answers``'s, where the caller has it."""
    classes = [str(c) for c in model.classes]
    threshold = model.doubt_margin
    others: Sequence[str | None] = [None] * len(names)
    opinion = second_opinion(model) if cross_check and len(records) else None
    if opinion == KNOWN_CHECK:
        others = list(model.known.nearest(records))
    elif opinion == SECOND_MODEL:
        others = model.second.names(records)
    elif opinion == CROSS_CHECK:
        others = seconding(names, cross_check_accepts(records, classes))
    novelty = getattr(model, "novelty", None)
    scores: Sequence[float | None] = [None] * len(names)
    if novelty is not None and len(records):
        x = model.features(records) if features is None else features
        scores = [float(v) for v in novelty.scores(x)]
    limit = None if novelty is None else novelty.threshold
    axis = getattr(model, "axis", None)
    verdicts: Sequence[Any] = [None] * len(names)
    if axis is not None and len(records):
        verdicts = axis.verdicts_many(records, names)
    return [
        answer_doubt(classes, str(n), None if proba is None else proba[i], threshold, others[i],
                     scores[i], limit, verdicts[i],
                     None if renamed_from is None else renamed_from[i])  # fmt: skip
        for i, n in enumerate(names)
    ]


def flagged_answers(found: Sequence[dict]) -> np.ndarray:
    """Which of :func:`doubts`' verdicts flag their answer: ambiguous or unknown."""
    return np.array([d["ambiguous"] is not None or bool(d["unknown"]) for d in found], bool)


def evaluation_doubt(
    model, records: Sequence, y_true, y_pred, proba, features: np.ndarray | None = None,
    renamed_from: Sequence[str | None] | None = None,
) -> dict[str, Any]:  # fmt: skip
    """``evaluate``'s ``ambiguous`` block: ``{"margin", "cross_check", "flagged",
    "right_flagged", "wrong_flagged", "renamed"}``, the model's threshold, its second opinion,
    the share of all, right and wrong answers flagged, and how many answers the grasps'
    contacts renamed (``Model.answers``; docs/json.md)."""
    found = doubts(model, records, y_pred, proba, features=features, renamed_from=renamed_from)
    flags = flagged_answers(found)
    unknown = np.array([d["unknown"] for d in found], dtype=bool)
    truth = np.asarray(y_true).astype(str)
    correct = np.asarray(y_pred).astype(str) == truth
    cross = second_opinion(model)
    family = np.isin(truth, [str(c) for c in model.classes])
    novelty = getattr(model, "novelty", None)

    def share(mask: np.ndarray) -> float | None:
        return float(np.mean(unknown[mask])) if mask.any() else None

    return {
        "margin": model.doubt_margin, "cross_check": cross, **flag_shares(flags, correct),
        "renamed": sum(d["renamed_from"] is not None for d in found),
        "unknown": {
            "threshold": None if novelty is None else novelty.threshold,
            "in_family": share(family), "out_of_family": share(~family),
            "in_family_grasps": int(family.sum()), "out_of_family_grasps": int((~family).sum()),
            "by_axis": int(sum(d["unknown_why"] == NOT_REVOLUTION for d in found)),
            "by_profile": int(sum(d["unknown_why"] == NOT_PROFILE for d in found)),
        },
    }  # fmt: skip


def pair_doubt(
    classifier: str, estimator, train: tuple, test: tuple, cache: dict | None = None
) -> dict[str, Any]:
    """A fitted pair's doubt on a test set (``compare``): its threshold (calibrated on held-out
    folds of the training set, ``train`` and ``test`` each ``(features, labels, records)``),
    the cross-check's answers on the test records where it applies (kept in ``cache`` for the
    next pair), and the share of all, right and wrong test answers flagged; ``reason`` instead
    of a threshold where it could not be calibrated."""
    from ..plugins import get_classifier

    x_train, y_train, records = train
    x_test, y_test, test_records = test
    classes = sorted({str(c) for c in y_train})
    seconds = None
    if cross_check_applies(classes, classifier):
        cache = {} if cache is None else cache
        if "seconds" not in cache:
            cache["seconds"] = cross_check_accepts(test_records, classes)
        seconds = cache["seconds"]
    calibration = calibrate_margin(
        lambda: get_classifier(classifier), x_train, y_train,
        records=records if seconds is not None else None, classifier=classifier,
    )  # fmt: skip
    names = np.asarray(estimator.predict(x_test)).astype(str)
    classes = [str(c) for c in estimator.classes_]
    proba = np.asarray(estimator.predict_proba(x_test), dtype=float)
    m = margins(proba, np.array([classes.index(n) for n in names]))[0]
    flags = flagged(m, calibration["margin"])
    if calibration["cross_check"] is not None and seconds is not None:
        flags = flags | cross_flags(names, seconds)
    doc = {"margin": calibration["margin"], "cross_check": calibration["cross_check"]}
    if calibration["margin"] is None:
        doc["reason"] = calibration.get("reason")
    return {**doc, **flag_shares(flags, names == np.asarray(y_test).astype(str))}
