"""Beyond one grasp: when in doubt, grasp again where the hypotheses differ most.

One grasp leaves some objects in doubt (docs/robustness.md): a turned cylinder reads as a
cone, a fat torus as a sphere. A second grasp at another pose separates them when the
remaining hypotheses predict different joint angles there. This module chooses that pose and
fuses the grasps' answers:

- **Fusion** (:mod:`.fusion`): the posterior over shapes after k grasps, the product of each
  grasp's smoothed probabilities, and the fused answer's ``ambiguous`` and ``unknown``.
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
from .fusion import (  # noqa: F401 - the fusing functions are exploration's API too
    SMOOTHING,
    SURE,
    fuse,
    fused_answer,
    grasp_answers,
    probabilities,
    settled,
    smoothed,
    unknown_against,
)

REACH = (0.015, 0.010, 25.0)
"""The reachable set: |offset along O-O'| (m), |offset along the fingers| (m), |rotation about
the palm normal| (deg). The fitted poses the shape fit searches, less a margin: a grasp beyond
it misses fingers or turns the object out of the calibrated range."""
MOVES: tuple[tuple[float, float, float], ...] = (
    (0.010, 0.0, 0.0), (-0.010, 0.0, 0.0), (0.0, 0.005, 0.0), (0.0, -0.005, 0.0),
    (0.0, 0.0, 20.0), (0.0, 0.0, -20.0), (0.0, 0.0, 0.0),
)  # fmt: skip
"""Candidate moves from the first grasp's pose: (dx m, dz m, dalpha deg); the last repeats it."""
MAX_GRASPS = len(MOVES)
"""Most grasps of one exploration: the first pose and its reachable moves. In simulation a
grasp made again at a pose is the same grasp and counts once, so more grasps add nothing."""
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

TURN_SECOND = False
"""Make the second grasp a turn of the hand about the palm normal (the reachable rotation
moves of :data:`MOVES`, the sign by expected gain; every move where no turn is reachable);
later grasps are planned over every move. Off: designed on seeds 4, 5 and 7, where random
turns had helped most, declared before seed 8 and reverted on it (docs/exploration.md, its
figures in docs/performance.md). ``benchmarks/active_switch.py`` turns it on."""

GAIN_BY_READINGS = False
"""Score a move by the information its reading carries about which hypothesis is true (the
mutual information between the hypothesis and the model's reading there, :func:`reading_gain`)
instead of by the fused posterior's expected entropy (:func:`expected_gain`), which also
rewards a move where every hypothesis would read as the same shape; a move to a pose already
grasped tells nothing new and is left out (where another is reachable). Off: declared before
seed 9 and reverted on it (docs/exploration.md, its figures in docs/performance.md);
``benchmarks/active_switch.py`` turns it on."""

FUSE_REPEATS = False
"""Fuse a grasp that repeats an earlier one (the same pose and final joint angles: in
simulation, the same grasp made again) as new evidence. Off: each distinct grasp counts once,
so grasping a pose again cannot make the answer surer (docs/exploration.md, declared before
seed 5); a real hand's grasps at one pose differ by their noise and are all fused."""


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


def visited(move: Sequence[float], first: Pose, grasped: Sequence[Pose]) -> bool:
    """Whether a grasp was made at the pose ``move`` takes ``first`` to (within 1 um and
    1e-6 deg)."""
    done = np.array([move_of(first, p) for p in grasped], float).reshape(-1, 3)
    return bool(np.any(np.all(np.abs(done - np.asarray(move, float)) <= 1e-6, axis=1)))


def unvisited(candidates: Sequence[Sequence[float]], first: Pose,
              grasped: Sequence[Pose]) -> list[tuple[float, float, float]]:
    """The candidate moves whose pose no grasp was made at (:func:`visited`); all of them
    where every one was."""
    left = [tuple(m) for m in candidates if not visited(m, first, grasped)]
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


# --- reading grasps by simulation ---------------------------------------------------------------


def _entropy(p: np.ndarray) -> float:
    p = np.asarray(p, float)
    p = p[p > 0]
    return float(-(p * np.log2(p)).sum())


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


def reading_gain(model, prior: np.ndarray, hyps: Sequence[Hypothesis], move, first: Pose,
                 controller: ControllerSettings, cache: SimulationCache,
                 outcomes: int = OUTCOMES) -> float:  # fmt: skip
    """Mutual information (bits) between which hypothesis is true (weighted by its posterior)
    and what the model reads at each hypothesis's pose moved by ``move``: the entropy of the
    readings' mixture less each hypothesis's own reading entropy. Each reading is the model's
    probabilities smoothed as fusing smooths them (:data:`SMOOTHING`), averaged over the
    hypothesis's simulated outcomes; a hypothesis without one reads as a uniform answer. Zero
    where every hypothesis reads alike, however surely (``prior`` and ``first`` are
    :func:`expected_gain`'s, unused here)."""
    weights = np.array([h.weight for h in hyps], float)
    weights = weights / weights.sum()
    n = len(model.classes)
    readings = []
    for h in hyps:
        pose = moved(h.pose, move)
        found = [r for sizes in _outcomes(h, outcomes)
                 if (r := cache.grasp(h.shape, sizes, pose, controller)) is not None]
        proba = model.predict_with_proba(found)[1] if found else None
        readings.append(smoothed(proba).mean(axis=0) if proba is not None else np.full(n, 1 / n))
    mixture = weights @ np.array(readings)
    return _entropy(mixture) - float(sum(w * _entropy(r) for w, r in zip(weights, readings,
                                                                          strict=True)))


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
    if AVOID_VISITED or GAIN_BY_READINGS:
        reachable = unvisited(reachable, first, [g.pose for g in grasps])
    if TURN_SECOND and len(keep) == 1:
        reachable = [m for m in reachable if m[2] != 0] or reachable
    cache.prefetch([(h.shape, sizes, moved(h.pose, move), controller) for move in reachable
                    for h in hyps for sizes in _outcomes(h, OUTCOMES)])  # fmt: skip
    gain = reading_gain if GAIN_BY_READINGS else expected_gain
    gains = {}
    for move in reachable:
        gains[tuple(move)] = (gain(model, prior, hyps, move, first, controller, cache)
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
    if (isinstance(max_grasps, bool) or not isinstance(max_grasps, int)
            or not 1 <= max_grasps <= MAX_GRASPS):  # fmt: skip
        raise UsageError(f"--max-grasps must be a whole number from 1 to {MAX_GRASPS} (the "
                         f"first pose and its reachable moves), got {max_grasps!r}")  # fmt: skip
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
    stopped: str | None = None
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
                              "seconds": time.perf_counter() - started,
                              "repeats": visited(decision["move"], first,
                                                 [g.pose for g in grasps])})  # fmt: skip
            if until_settled and not FUSE_REPEATS and decisions[-1]["repeats"]:
                # the same grasp again, counted once: the next decision would be this one
                stopped = REPEAT_STOP
                break
        elif strategy == "random":
            options = [m for m in reachable_moves(first) if any(m)]
            pose = moved(first, options[int(rng.integers(len(options)))])
        else:
            pose = first
    return {"answer": fused, "grasps": entries, "decisions": decisions, "fused": history,
            "stopped": stopped}


REPEAT_STOP = ("the planner's next pose is one already grasped: in simulation the same grasp, "
               "counted once, so neither it nor any later decision could change the answer")
"""Why a planned loop ends before ``max_grasps`` while still in doubt (``explore``'s
``stopped``)."""


def _pose_doc(pose: Pose) -> dict[str, Any]:
    return {"offset": list(pose.offset), "rotation_deg": math.degrees(pose.rotation)}


def _pose_text(pose: Pose) -> str:
    x, _, z = pose.offset
    return (f"offset {1000 * x:+.0f} mm along O-O', {1000 * z:+.0f} mm along the fingers, "
            f"turned {math.degrees(pose.rotation):+.0f} deg")  # fmt: skip


__all__ = ["Grasp", "MOVES", "REACH", "check_reachable", "explore", "fuse", "fused_answer",
           "next_pose", "plan"]  # fmt: skip
