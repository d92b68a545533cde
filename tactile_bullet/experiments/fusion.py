"""Fusing the grasps of one object: the posterior over shapes after k grasps and the fused
answer's doubt (``ambiguous``, ``unknown``), from each grasp's own answer.

The posterior is the normalised product of each grasp's probabilities, each first mixed with
``SMOOTHING`` of a uniform answer (a knn's 0/0.2/../1 probabilities would otherwise let one
grasp veto a shape for good); ``ambiguous`` where the best shape's posterior is under ``SURE``
(after one grasp, also where that grasp's own answer is ambiguous: its second opinion
disagrees); ``unknown`` where at least half the grasps are unknown, each grasp's contacts
judged against the fused family (:data:`UNKNOWN_AGAINST_FUSED`). ``explore``
(:mod:`.exploration`) and ``identify --recording`` (``realhand/recordings.py``) fuse this way.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..records import GraspRecord

SMOOTHING = 0.05
"""Share of a uniform answer mixed into each grasp's probabilities before they are fused."""
SURE = 0.8
"""Posterior of the best shape at or above which a fused answer is not ambiguous."""
UNKNOWN_AGAINST_FUSED = True
"""Judge each grasp's contacts against the fused family, not against the family that grasp
alone named: a grasp read as a cylinder whose normals miss a cylinder's tight axis threshold
may still be a hyperboloid's, the family the grasps together name. A grasp whose features lie
beyond the model's training grasps (the novelty rule) stays unknown whatever the family.
Declared before seed 7 and kept on it (docs/exploration.md); ``benchmarks/active_unknown.py``
scores it against the grasps' own flags."""


def smoothed(proba: np.ndarray) -> np.ndarray:
    """Probabilities mixed with ``SMOOTHING`` of a uniform answer (rows sum to 1)."""
    proba = np.asarray(proba, float)
    return (1 - SMOOTHING) * proba + SMOOTHING / proba.shape[-1]


def fuse(probas: Sequence[np.ndarray]) -> np.ndarray:
    """The posterior over the model's classes after the grasps whose probabilities are
    ``probas`` (a uniform prior; each grasp's answer smoothed)."""
    log = np.sum([np.log(smoothed(p)) for p in probas], axis=0)
    post = np.exp(log - log.max())
    return post / post.sum()


def grasp_answers(model, records: Sequence[GraspRecord]) -> list[dict[str, Any]]:
    """Each grasp's own answer (``training.identify``'s document), without the progress
    lines of each one-grasp second opinion (the loop reports per grasp itself)."""
    from ..console import reporting
    from .training import identify

    with reporting(False):
        return [identify(model, r) for r in records]


def probabilities(model, answer: Mapping[str, Any]) -> np.ndarray:
    """An answer's probabilities in the model's class order (uniform where it named none).
    Where the grasp's contacts renamed the classifier's answer (``renamed_from``: they fit no
    such shape but the one named), the classifier's probability of the shape they reject
    counts toward the shape they name, so the fused answer of one grasp is that grasp's."""
    classes = [str(c) for c in model.classes]
    probs = answer.get("probabilities") or {}
    if not probs:
        return np.full(len(classes), 1.0 / len(classes))
    out = np.array([float(probs.get(c, 0.0)) for c in classes])
    rejected, named = answer.get("renamed_from"), answer.get("shape")
    if rejected in classes and named in classes:
        out[classes.index(named)] += out[classes.index(rejected)]
        out[classes.index(rejected)] = 0.0
    return out


def fused_answer(model, answers: Sequence[Mapping[str, Any]],
                 likelihoods: Sequence[np.ndarray] | None = None,
                 records: Sequence[GraspRecord] | None = None) -> dict[str, Any]:  # fmt: skip
    """The answer after every grasp so far: ``shape`` (the posterior's best), ``posterior``
    ({shape: p}), ``ambiguous`` ([best, runner-up] while the best is under ``SURE``, else
    None), ``unknown`` (at least half the grasps are unknown) and ``unknown_grasps`` (how many
    are). With ``likelihoods`` (the later grasps read by simulation,
    :func:`.exploration.simulated_likelihoods`) the posterior is the first grasp's answer
    times them, in place of the later grasps' own answers. With the grasps' ``records`` (one
    per answer) and :data:`UNKNOWN_AGAINST_FUSED`, each grasp counts as unknown as
    :func:`unknown_against` judges it against the fused family."""
    classes = [str(c) for c in model.classes]
    if likelihoods is None:
        post = fuse([probabilities(model, a) for a in answers])
    else:
        post = fuse([probabilities(model, answers[0]), *likelihoods])
    order = np.argsort(-post)
    best, second = classes[order[0]], classes[order[1]]
    if records is not None and UNKNOWN_AGAINST_FUSED:
        flags = unknown_against(model, answers, records, best)
    else:
        flags = [bool(a.get("unknown")) for a in answers]
    unknown = sum(flags) * 2 >= len(answers)
    ambiguous = None if post[order[0]] >= SURE else [best, second]
    if len(answers) == 1 and answers[0].get("ambiguous"):  # one grasp: its own doubt stands
        ambiguous = list(answers[0]["ambiguous"])
    return {
        "shape": best,
        "posterior": {c: float(p) for c, p in zip(classes, post, strict=True)},
        "ambiguous": ambiguous,
        "unknown": bool(unknown),
        "unknown_grasps": int(sum(flags)),
        "grasps": len(answers),
    }


def unknown_against(model, answers: Sequence[Mapping[str, Any]],
                    records: Sequence[GraspRecord], family: str) -> list[bool]:
    """Whether each grasp is unknown to ``family``: its own answer's flag where it named that
    family or its novelty (family-blind) made it unknown; else what its contacts say of
    ``family`` (the model's axis and profile thresholds for it, on the grasp's engine). A
    model without a contact check, or a grasp without contacts, keeps its own flag."""
    from ..learn.doubt import UNLIKE_TRAINING

    if len(records) != len(answers):
        raise ValueError(f"{len(answers)} answers but {len(records)} records")
    flags = [bool(a.get("unknown")) for a in answers]
    check = getattr(model, "axis", None)
    asked = [i for i, a in enumerate(answers)
             if check is not None and a.get("shape") != family
             and a.get("unknown_why") != UNLIKE_TRAINING]  # fmt: skip
    if not asked:
        return flags
    found = check.verdicts([records[i] for i in asked], [family] * len(asked))
    for i, verdict in zip(asked, found, strict=True):
        if verdict.axis_residual is not None:  # contacts judged: their verdict on the family
            flags[i] = verdict.unknown_why is not None
    return flags


def settled(answer: Mapping[str, Any]) -> bool:
    """Whether a fused answer needs no further grasp."""
    return answer["ambiguous"] is None and not answer["unknown"]
