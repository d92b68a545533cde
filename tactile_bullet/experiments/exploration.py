"""Beyond one grasp: when in doubt, grasp again where the hypotheses differ most.

One grasp leaves some objects in doubt (docs/robustness.md): a turned cylinder reads as a
cone, a fat torus as a sphere. A second grasp at another pose separates them when the
remaining hypotheses predict different joint angles there. This module chooses that pose and
fuses the grasps' answers:

- **Fusion** (:func:`fuse`): the posterior over shapes after k grasps is the normalised product
  of each grasp's probabilities, each first mixed with ``SMOOTHING`` of a uniform answer (a
  knn's 0/0.2/../1 probabilities would otherwise let one grasp veto a shape for good);
  ``ambiguous`` where the best shape's posterior is under ``SURE`` (after one grasp, also where
  that grasp's own answer is ambiguous: its second opinion disagrees), ``unknown`` where at
  least half the grasps are unknown, each grasp's contacts judged against the fused family
  (:data:`UNKNOWN_AGAINST_FUSED`).
- **Planning** (:func:`next_pose`): each hypothesis is a shape family with the sizes and pose
  the training-free shape fit gives it on the first grasp. For each candidate move of the hand
  (:data:`MOVES`: along O-O', across it, turned about the palm normal) that keeps the grasp in
  the reachable set (:data:`REACH`), every likely hypothesis is simulated at its pose moved so
  (its fitted sizes, and ``SIZE_STEP`` larger and smaller); the model reads each simulated
  grasp, and the move whose expected posterior entropy is lowest (the largest expected
  information gain) is chosen. Simulations are cached by object and pose, so a second decision
  on the same object costs only its new poses, and a decision's new ones run on every core
  (:meth:`SimulationCache.prefetch`).

Poses here are the object's pose relative to the hand (``Pose``), as every grasp takes it; a
move of the hand by (dx, dz, dalpha) moves the object by the opposite in the hand's frame, and
the planner only ever adds moves to the first grasp's pose, so a real hand's driver can run
the loop with relative moves (``next_pose`` returns the pose; the move is its difference from
the first grasp's).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import UsageError
from ..records import ControllerSettings, GraspRecord, Pose

SMOOTHING = 0.05
"""Share of a uniform answer mixed into each grasp's probabilities before they are fused."""
SURE = 0.8
"""Posterior of the best shape at or above which a fused answer is not ambiguous."""
REACH = (0.015, 0.010, 25.0)
"""The reachable set: |offset along O-O'| (m), |offset along the fingers| (m), |rotation about
the palm normal| (deg). The fitted poses the shape fit searches, less a margin: a grasp beyond
it misses fingers or turns the object out of the calibrated range."""
MOVES: tuple[tuple[float, float, float], ...] = (
    (0.010, 0.0, 0.0), (-0.010, 0.0, 0.0), (0.0, 0.005, 0.0), (0.0, -0.005, 0.0),
    (0.0, 0.0, 20.0), (0.0, 0.0, -20.0), (0.0, 0.0, 0.0),
)  # fmt: skip
"""Candidate moves from the first grasp's pose: (dx m, dz m, dalpha deg); the last repeats it."""
HYPOTHESES = 3
"""Most likely shapes simulated per decision."""
SIZE_STEP = 0.08
"""Relative size change of the second and third simulated outcome of each hypothesis."""
OUTCOMES = 1
"""Simulated outcomes per hypothesis and move (fitted sizes, then larger, then smaller): one
keeps a decision near a second on MuJoCo (docs/exploration.md)."""
OWN_HAND_HYPOTHESES = False
"""Fit the hypotheses to the first grasp with the coefficients of the hand that made it where
the package has them (our MuJoCo hand: ``hand_calibration.record_calibration``), as the doubt's
cross-check reads it. Off: declared and judged on seed 3 of the ``active`` protocol, it gained
3 objects after three grasps and 2 with the stopping rule but lost 2 border objects after two
grasps, beyond the declared limit of one (docs/exploration.md); the hypotheses are fitted with
the coefficients in force. ``benchmarks/active_switch.py`` turns it on."""
AVOID_VISITED = False
"""Leave out of the planner's candidates every move to a pose already grasped (a grasp there
repeats what was read, while the expected gain counts it as new evidence). Off: declared and
judged on seed 2 of the ``active`` protocol, it gained no object after three grasps and lost
one with the stopping rule (docs/exploration.md); ``benchmarks/active_switch.py`` turns it
on to reproduce that."""


FUSE_REPEATS = False
"""Fuse a grasp that repeats an earlier one (the same pose and final joint angles: in
simulation, the same grasp made again) as new evidence. Off: each distinct grasp counts once,
so grasping a pose again cannot make the answer surer (docs/exploration.md, declared before
seed 5); a real hand's grasps at one pose differ by their noise and are all fused."""

UNKNOWN_AGAINST_FUSED = True
"""Judge each grasp's contacts against the fused family, not against the family that grasp
alone named: a grasp read as a cylinder whose normals miss a cylinder's tight axis threshold
may still be a hyperboloid's, the family the grasps together name. A grasp whose features lie
beyond the model's training grasps (the novelty rule) stays unknown whatever the family.
Declared before seed 7 and kept on it (docs/exploration.md); ``benchmarks/active_unknown.py``
scores it against the grasps' own flags."""


@dataclass(frozen=True)
class Grasp:
    """One grasp of the object: its record and the pose it was made at."""

    record: GraspRecord
    pose: Pose


def check_reachable(pose: Pose, what: str = "pose") -> Pose:
    """``pose`` if it lies in :data:`REACH`, else a UsageError saying which bound it passes."""
    x, _, z = pose.offset
    deg = math.degrees(pose.rotation)
    limits = (("offset along O-O'", x, REACH[0], "m"), ("offset along the fingers", z, REACH[1],
              "m"), ("rotation", deg, REACH[2], "deg"))  # fmt: skip
    for name, value, bound, unit in limits:
        if abs(value) > bound + 1e-12:
            raise UsageError(f"{what}: {name} {value:g} {unit} is outside the reachable set "
                             f"(+-{bound:g} {unit}; docs/exploration.md)")  # fmt: skip
    return pose


def moved(pose: Pose, move: Sequence[float]) -> Pose:
    """``pose`` with a move (dx m, dz m, dalpha deg) added."""
    x, y, z = pose.offset
    return Pose((x + move[0], y, z + move[1]), pose.rotation + math.radians(move[2]))


def move_of(first: Pose, pose: Pose) -> tuple[float, float, float]:
    """The move (dx m, dz m, dalpha deg) that takes ``first`` to ``pose`` (:func:`moved`'s
    inverse)."""
    return (pose.offset[0] - first.offset[0], pose.offset[2] - first.offset[2],
            math.degrees(pose.rotation - first.rotation))  # fmt: skip


def distinct(grasps: Sequence[Grasp]) -> list[int]:
    """Indices of the grasps the fused answer counts: every one under :data:`FUSE_REPEATS`,
    else each grasp once, one whose pose and final joint angles equal an earlier grasp's left
    out."""
    if FUSE_REPEATS:
        return list(range(len(grasps)))
    seen: set[tuple] = set()
    keep = []
    for i, g in enumerate(grasps):
        final = np.asarray(g.record.final_angles, dtype=float)
        key = (tuple(g.pose.offset), float(g.pose.rotation), final.tobytes())
        if key not in seen:
            seen.add(key)
            keep.append(i)
    return keep


def unvisited(candidates: Sequence[Sequence[float]], first: Pose,
              grasped: Sequence[Pose]) -> list[tuple[float, float, float]]:
    """The candidate moves whose pose no grasp was made at (within 1 um and 1e-6 deg); all of
    them where every one was."""
    done = np.array([move_of(first, p) for p in grasped], float).reshape(-1, 3)
    tol = np.array([1e-6, 1e-6, 1e-6])
    left = [tuple(m) for m in candidates
            if not np.any(np.all(np.abs(done - np.asarray(m, float)) <= tol, axis=1))]
    return left or [tuple(m) for m in candidates]


def reachable_moves(first: Pose, moves=MOVES) -> list[tuple[float, float, float]]:
    """The moves that keep the first grasp's pose in the reachable set."""
    out = []
    for move in moves:
        try:
            check_reachable(moved(first, move))
        except UsageError:
            continue
        out.append(tuple(move))
    return out


# --- fusing grasps ------------------------------------------------------------------------------


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


def _entropy(p: np.ndarray) -> float:
    p = np.asarray(p, float)
    p = p[p > 0]
    return float(-(p * np.log2(p)).sum())


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
    None) and ``unknown`` (at least half the grasps answered unknown). With ``likelihoods``
    (the later grasps read by simulation, :func:`simulated_likelihoods`) the posterior is the
    first grasp's answer times them, in place of the later grasps' own answers. With the
    grasps' ``records`` (one per answer) and :data:`UNKNOWN_AGAINST_FUSED`, each grasp counts
    as unknown as :func:`unknown_against` judges it against the fused family."""
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


def simulated_likelihoods(model, grasps: Sequence[Grasp], hyps: Sequence[Hypothesis],
                          controller: ControllerSettings,
                          cache: SimulationCache) -> list[np.ndarray]:  # fmt: skip
    """For each grasp after the first, how well each of the model's classes explains it by
    simulation: the hypothesis of that class simulated at its fitted pose moved as the hand
    moved, compared with the grasp in the model's features (scaled as its novelty scales
    them); likelihood exp(-d^2 / 2 t^2) with t the novelty threshold (the spread of a grasp
    about its nearest training grasps). A class with no hypothesis gets the least likelihood
    any hypothesis got (the simulator says nothing for it)."""
    novelty = getattr(model, "novelty", None)
    if novelty is None or not hyps or len(grasps) < 2:
        return []
    classes = [str(c) for c in model.classes]
    first = grasps[0].pose
    out = []
    for g in grasps[1:]:
        move = move_of(first, g.pose)
        observed = (model.features([g.record])[0] - novelty.centre) / novelty.scale
        like = {}
        for h in hyps:
            record = cache.grasp(h.shape, h.params, moved(h.pose, move), controller)
            if record is None:
                continue
            predicted = (model.features([record])[0] - novelty.centre) / novelty.scale
            d = float(np.linalg.norm(observed - predicted))
            like[h.shape] = math.exp(-0.5 * (d / max(novelty.threshold, 1e-9)) ** 2)
        if not like:
            continue
        floor = min(like.values())
        row = np.array([like.get(c, floor) for c in classes]) + 1e-12
        out.append(row / row.sum())
    return out


def settled(answer: Mapping[str, Any]) -> bool:
    """Whether a fused answer needs no further grasp."""
    return answer["ambiguous"] is None and not answer["unknown"]


# --- planning -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Hypothesis:
    """A shape the object may be: the family, its fitted sizes and its fitted pose at the
    first grasp, and its posterior."""

    shape: str
    params: dict[str, float]
    pose: Pose
    weight: float


def hypotheses(model, grasps: Sequence[Grasp], answer: Mapping[str, Any],
               k: int = HYPOTHESES) -> list[Hypothesis]:  # fmt: skip
    """The ``k`` likeliest shapes the shape fit can model, each with the sizes and pose it
    fits to the first grasp (with its own hand's coefficients under
    :data:`OWN_HAND_HYPOTHESES`)."""
    from ..learn.robust import angles_for_shape_fit
    from ..perception.shape_fit import fit_family, fitted_shapes
    from ..perception.shape_model import use_own
    from ..realhand.hand_calibration import record_calibration

    modelled = set(fitted_shapes())
    ranked = sorted(answer["posterior"].items(), key=lambda kv: -kv[1])
    out = []
    first = grasps[0]
    own = record_calibration(first.record) if OWN_HAND_HYPOTHESES else None
    with use_own(own):
        angles = angles_for_shape_fit(first.record)
    for shape, weight in ranked:
        if shape not in modelled or weight <= 0:
            continue
        fit = fit_family(angles, shape, own)
        x, z = fit.offset
        pose = Pose((x, 0.0, z), math.radians(fit.rotation_deg))
        out.append(Hypothesis(shape, dict(fit.params), pose, float(weight)))
        if len(out) == k:
            break
    return out


PARALLEL_SIMULATIONS = 4
"""Fewest new hypothesis grasps a decision simulates on forked workers: a MuJoCo grasp takes
40-120 ms, starting a forked worker a few ms."""

Job = tuple[str, Mapping[str, float], Pose, ControllerSettings]
"""One hypothesis grasp to simulate: shape, sizes, pose, controller."""


def _simulate(job: Job) -> GraspRecord | None:
    """The grasp of ``job``; None where the simulator refuses its size or pose (no outcome
    there)."""
    from ..sim.grasp import simulate_grasp

    try:
        return simulate_grasp(*job)
    except UsageError:
        return None


@dataclass
class SimulationCache:
    """Simulated hypothesis grasps, by (shape, sizes, pose, controller): a decision reuses
    every grasp an earlier one made on the same object."""

    records: dict[tuple, GraspRecord] = field(default_factory=dict)
    simulated: int = 0

    @staticmethod
    def _key(shape: str, params: Mapping[str, float], pose: Pose,
             controller: ControllerSettings) -> tuple:  # fmt: skip
        return (shape, tuple(sorted((k, round(v, 5)) for k, v in params.items())),
                tuple(round(v, 5) for v in pose.offset), round(pose.rotation, 5),
                controller)  # fmt: skip

    def grasp(self, shape: str, params: Mapping[str, float], pose: Pose,
              controller: ControllerSettings) -> GraspRecord | None:  # fmt: skip
        key = self._key(shape, params, pose, controller)
        if key not in self.records:
            self.records[key] = _simulate((shape, params, pose, controller))
            self.simulated += 1
        return self.records[key]

    def prefetch(self, jobs: Sequence[Job]) -> None:
        """Simulate every job the cache lacks, over every core this process may use where
        forking is safe and worth it (``fit_batch.can_fork``, at least
        :data:`PARALLEL_SIMULATIONS` new grasps), else here: a decision's grasps are
        independent and deterministic, so each is the one :meth:`grasp` would make."""
        from ..perception.fit_batch import on_cores

        todo: dict[tuple, Job] = {}
        for job in jobs:
            key = self._key(*job)
            if key not in self.records:
                todo[key] = job
        keys, pending = list(todo), list(todo.values())
        found = on_cores(lambda index: [_simulate(pending[i]) for i in index], len(pending),
                         PARALLEL_SIMULATIONS, 1)  # fmt: skip
        for key, record in zip(keys, found, strict=True):
            self.records[key] = record
            self.simulated += 1


def _outcomes(h: Hypothesis, n: int) -> list[dict[str, float]]:
    """The hypothesis's fitted sizes, then scaled by +-SIZE_STEP, clipped to its ranges."""
    from ..plugins import get_shape

    spec = get_shape(h.shape)
    scales = (1.0, 1.0 + SIZE_STEP, 1.0 - SIZE_STEP)[:n]
    out = []
    for s in scales:
        sizes = {}
        for name, value in h.params.items():
            p = spec.params[name]
            sizes[name] = float(np.clip(value * s, p.min, p.max))
        out.append(sizes)
    return out


def expected_gain(model, prior: np.ndarray, hyps: Sequence[Hypothesis], move, first: Pose,
                  controller: ControllerSettings, cache: SimulationCache,
                  outcomes: int = OUTCOMES) -> float:  # fmt: skip
    """Expected information gain (bits) of grasping at the first pose moved by ``move``:
    the prior's entropy minus the expected entropy of the posterior after that grasp, each
    hypothesis weighted by its posterior and simulated at its own fitted pose moved so."""
    weights = np.array([h.weight for h in hyps], float)
    weights = weights / weights.sum()
    expected = 0.0
    for h, w in zip(hyps, weights, strict=True):
        pose = moved(h.pose, move)
        found = [r for sizes in _outcomes(h, outcomes)
                 if (r := cache.grasp(h.shape, sizes, pose, controller)) is not None]
        if not found:  # no simulated outcome: this move tells nothing about this hypothesis
            expected += w * _entropy(prior)
            continue
        _, proba = model.predict_with_proba(found)
        for row in proba if proba is not None else [None] * len(found):
            post = fuse([prior, row]) if row is not None else prior
            expected += w * _entropy(post) / len(found)
    return _entropy(prior) - expected


def next_pose(
    grasps: Sequence[Grasp],
    model=None,
    controller: ControllerSettings | None = None,
    moves: Sequence[Sequence[float]] = MOVES,
    cache: SimulationCache | None = None,
) -> Pose:
    """The pose of the next grasp: among the first grasp's pose moved by each of ``moves``
    (within the reachable set), the one whose expected information gain is the largest
    (module doc). ``model``: the default identifier where None; ``controller``: the engine
    and settings the hypotheses are simulated with (the first grasp's where None)."""
    from ..learn.default import resolve_model

    if not grasps:
        raise UsageError("next_pose needs at least one grasp")
    model = resolve_model(None) if model is None else model
    controller = controller or grasps[0].record.controller
    cache = cache if cache is not None else SimulationCache()
    return plan(grasps, model, controller, moves, cache)["pose"]


def plan(grasps: Sequence[Grasp], model, controller: ControllerSettings,
         moves: Sequence[Sequence[float]] = MOVES, cache: SimulationCache | None = None,
         answers: Sequence[Mapping[str, Any]] | None = None) -> dict[str, Any]:  # fmt: skip
    """:func:`next_pose`'s decision with its reasons: ``pose``, ``move``, ``gains`` (bits,
    per move), ``hypotheses`` and ``simulated`` (new hypothesis grasps this decision).
    ``answers``: each grasp's own answer, where the caller has them (:func:`explore`)."""
    cache = cache if cache is not None else SimulationCache()
    keep = distinct(grasps)
    if answers is None:
        answers = grasp_answers(model, [grasps[i].record for i in keep])
    else:
        answers = [answers[i] for i in keep]
    fused = fused_answer(model, answers)
    prior = np.array([fused["posterior"][str(c)] for c in model.classes])
    hyps = hypotheses(model, grasps, fused)
    first = grasps[0].pose
    before = cache.simulated
    reachable = reachable_moves(first, moves)
    if AVOID_VISITED:
        reachable = unvisited(reachable, first, [g.pose for g in grasps])
    cache.prefetch([(h.shape, sizes, moved(h.pose, move), controller) for move in reachable
                    for h in hyps for sizes in _outcomes(h, OUTCOMES)])  # fmt: skip
    gains = {}
    for move in reachable:
        gains[tuple(move)] = (expected_gain(model, prior, hyps, move, first, controller, cache)
                              if hyps else 0.0)  # fmt: skip
    if not gains:
        raise UsageError("no move keeps the grasp in the reachable set")
    best = max(gains, key=lambda m: (round(gains[m], 9), -_size(m)))
    return {"pose": moved(first, best), "move": best, "gains": gains,
            "hypotheses": [(h.shape, h.weight) for h in hyps],
            "simulated": cache.simulated - before}  # fmt: skip


def _size(move) -> float:
    """How far a move goes (a tie goes to the smaller move)."""
    return abs(move[0]) / 0.01 + abs(move[1]) / 0.005 + abs(move[2]) / 20.0


# --- the loop -----------------------------------------------------------------------------------


def explore(
    target,
    params: Mapping[str, float] | None,
    first: Pose,
    controller: ControllerSettings,
    max_grasps: int = 3,
    model=None,
    strategy: str = "planned",
    seed: int = 0,
    cache: SimulationCache | None = None,
    log: Callable[[str], None] | None = None,
    until_settled: bool = True,
    fusion: str = "model",
) -> dict[str, Any]:
    """Grasp ``target`` (a shape name or Shape, with ``params``) at ``first``, then again while
    the fused answer is ambiguous or unknown, up to ``max_grasps``; each next pose by
    ``strategy``: ``planned`` (:func:`next_pose`), ``random`` (a reachable move drawn with
    ``seed``) or ``repeat`` (the first pose again). Returns ``{"answer", "grasps",
    "decisions"}``: the fused answer, one entry per grasp made (``pose``, ``answer``,
    ``posterior``), each planning decision's cost, and ``fused``, the fused answer after each
    grasp. ``until_settled`` False grasps ``max_grasps`` times whatever the answer (the
    ``active`` protocol scores every count). ``fusion``: ``model`` (the grasps' own answers,
    :func:`fuse`) or ``simulated`` (the first grasp's answer times, for each later grasp, how
    well each hypothesis simulated at that pose explains it: :func:`simulated_likelihoods`)."""
    import time

    from ..learn.default import resolve_model
    from ..sim.grasp import simulate_grasp

    if strategy not in ("planned", "random", "repeat"):
        raise UsageError(f"unknown strategy {strategy!r} (planned, random, repeat)")
    if fusion not in ("model", "simulated"):
        raise UsageError(f"unknown fusion {fusion!r} (model, simulated)")
    if isinstance(max_grasps, bool) or not isinstance(max_grasps, int) or max_grasps < 1:
        raise UsageError(f"--max-grasps must be a whole number >= 1, got {max_grasps!r}")
    check_reachable(first, "the first pose")
    model = resolve_model(None) if model is None else model
    cache = cache if cache is not None else SimulationCache()
    rng = np.random.default_rng(seed)
    say = log or (lambda _m: None)
    grasps: list[Grasp] = []
    entries: list[dict[str, Any]] = []
    decisions: list[dict[str, Any]] = []
    history: list[dict[str, Any]] = []
    hyps: list[Hypothesis] | None = None
    answers: list[dict[str, Any]] = []
    pose = first
    while True:
        record = simulate_grasp(target, params, pose, controller, seed=seed)
        grasps.append(Grasp(record, pose))
        answers += grasp_answers(model, [record])  # each grasp identified once
        keep = distinct(grasps)
        counted = [grasps[i] for i in keep]
        records = [g.record for g in counted]
        fused = fused_answer(model, [answers[i] for i in keep], records=records)
        if fusion == "simulated" and len(counted) > 1:
            if hyps is None:
                hyps = hypotheses(model, grasps[:1], fused_answer(model, answers[:1]))
            rows = simulated_likelihoods(model, counted, hyps, controller, cache)
            fused = fused_answer(model, [answers[i] for i in keep], rows, records=records)
        fused["grasps"] = len(grasps)  # made; the posterior counts each distinct one once
        fused["distinct_grasps"] = len(keep)
        history.append(fused)
        entries.append({"pose": _pose_doc(pose), "answer": answers[-1],
                        "posterior": fused["posterior"]})  # fmt: skip
        say(f"grasp {len(grasps)} at {_pose_text(pose)}: {answers[-1]['shape']}; posterior "
            f"best {fused['shape']} {fused['posterior'][fused['shape']]:.2f}")  # fmt: skip
        if (until_settled and settled(fused)) or len(grasps) >= max_grasps:
            break
        started = time.perf_counter()
        if strategy == "planned":
            decision = plan(grasps, model, controller, cache=cache, answers=answers)
            pose = decision["pose"]
            decisions.append({"move": list(decision["move"]),
                              "gains_bits": {str(list(m)): g for m, g in
                                             decision["gains"].items()},
                              "hypotheses": decision["hypotheses"],
                              "simulated": decision["simulated"],
                              "seconds": time.perf_counter() - started})  # fmt: skip
        elif strategy == "random":
            options = [m for m in reachable_moves(first) if any(m)]
            pose = moved(first, options[int(rng.integers(len(options)))])
        else:
            pose = first
    return {"answer": fused, "grasps": entries, "decisions": decisions, "fused": history}


def _pose_doc(pose: Pose) -> dict[str, Any]:
    return {"offset": list(pose.offset), "rotation_deg": math.degrees(pose.rotation)}


def _pose_text(pose: Pose) -> str:
    x, _, z = pose.offset
    return (f"offset {1000 * x:+.0f} mm along O-O', {1000 * z:+.0f} mm along the fingers, "
            f"turned {math.degrees(pose.rotation):+.0f} deg")  # fmt: skip


__all__ = ["Grasp", "MOVES", "REACH", "check_reachable", "explore", "fuse", "fused_answer",
           "next_pose", "plan"]  # fmt: skip
