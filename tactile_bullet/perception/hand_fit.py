"""A hand calibrated from a few grasps of known shape: the shape fit's 24 coefficients refitted.

The shape fit (``shape_fit.py``) predicts each long finger's J3 and J0 = J1 + J2 from the
object's geometry, then corrects the prediction linearly per finger and joint group
(``shape_model.Calibration``: intercept, gain, sideways term; 2 x 4 each). The shipped
coefficients were fitted on Bullet grasps at known sizes and poses. Another hand closes
differently (torque thresholds, friction, phalanx lengths, tendon rule, sensor offsets), and its
user knows only what each calibration object is. :func:`fit_hand` alternates

1. with the current coefficients, fit each grasp's own family (its label) for sizes, offset and
   rotation (only the pose where the user gave the object's sizes);
2. at those fitted sizes and poses, regress the measured angles on the geometric prediction per
   finger and joint group, by ridge regression pulled toward the starting coefficients.

How hard the start pulls is chosen by cross-validation over the calibration grasps themselves
(folds stratified by shape): each strength's coefficients, fitted without a fold, name the
fold's grasps among the calibration shapes; the most right answers win, then the widest mean
margin (by how much the labelled family beats the best other), then the stronger pull. The
starting coefficients are one of the candidates, so a calibration that does not help on grasps
it has not seen is never written: a hand is never made worse than the shipped coefficients on
the evidence at hand.

A uniform J3 offset is only partly identifiable from labels alone (the fitted object offset
along the fingers absorbs most of it); the intercepts take what the data allows, and the
offsets reported are the intercepts' change from the start.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..errors import UsageError
from ..objects.shapes import check_consistent
from .fit_batch import fit_many
from .shape_fit import (
    OFFSET_STEPS,
    OFFSET_X,
    OFFSET_Z,
    ROTATION,
    ROTATION_STEPS,
    _objective,
    _resolve_family,
    fit_shape,
    fitted_shapes,
    measured_features,
)
from .shape_model import Calibration, geometric_features, load_calibration

ROUNDS = 3
"""Alternations of (fit each grasp's pose and size, refit the coefficients)."""

STRENGTHS = (4.0, 1.0, 0.25, 0.0625)
"""Ridge strengths tried, as multiples of the calibration grasps: the pull toward the starting
coefficients weighs as much as this many times the grasps the fit is given. Relative, because
on the other hand measured (``benchmarks/hand_calibration.py``) a fixed pull let 50 grasps drag the
coefficients into a self-consistent fit that explains each grasp's own family better and tells
the families apart worse (10 per shape: 96.7% with a 32-grasp pull, 88.3% with 0.5). The
weakest is for a hand far from the shipped one: on MuJoCo grasps, 12 per shape, held-out
calibration grasps named right rose 44 -> 49 -> 54 of 60 from the shipped coefficients to
a pull of 1 and 0.25."""

GAIN_PULL = 10.0
"""How much harder the gains and sideways terms are pulled than the intercepts: a gain trades
against the fitted sizes (a larger gain, a smaller object), an intercept much less so."""

FAMILY_PULL = 1.0
"""How hard each family's offset (known sizes only) is pulled toward the start's (0 for the
shipped coefficients), as a multiple of the intercepts' pull. From labels alone the fitted
sizes take up a family's offset, and offsets fitted then named fewer grasps right on MuJoCo
(docs/calibration.md), so there are none."""

SIGMA_PRIOR = 0.25
"""The start's sigma pooled with the residual spread of grasps of known sizes, worth this many
times the grasps."""

SIGMA_INFLATE = 1.5
"""Residuals at fitted poses understate the spread on unseen grasps (3 pose coordinates fitted
to 8 angles: 8 / 5); their squares are scaled by this."""

MARGIN_CLIP = 10.0
"""Held-out margins (best other family's score minus the labelled one's) are clipped to
+-this before averaging: one far-off grasp must not outvote the rest."""

FOLDS = 3
"""Cross-validation folds (fewer where there are fewer grasps of each shape)."""

POSE_ROUNDS = 6
"""Pattern-search rounds of the pose-only fit (known sizes) after its grid."""


@dataclass(frozen=True)
class HandFit:
    """What :func:`fit_hand` found: the coefficients to use, the ridge strength chosen (None:
    the starting coefficients kept), the grasps per shape and the cross-validation report."""

    calibration: Calibration
    strength: float | None
    grasps_per_shape: dict[str, int]
    report: dict

    @property
    def kept_start(self) -> bool:
        return self.strength is None


def _pose_grid() -> np.ndarray:
    axes = [np.linspace(*OFFSET_X, OFFSET_STEPS[0]), np.linspace(*OFFSET_Z, OFFSET_STEPS[1]),
            np.linspace(*ROTATION, ROTATION_STEPS)]  # fmt: skip
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


_LO = np.array([OFFSET_X[0], OFFSET_Z[0], ROTATION[0]])
_HI = np.array([OFFSET_X[1], OFFSET_Z[1], ROTATION[1]])


def _fit_pose(measured: np.ndarray, shape: str, sizes: Mapping[str, float], cal: Calibration):
    """(3,) pose (offset along O-O', along the fingers, rotation in rad) of an object of known
    ``sizes`` that best explains ``measured`` (2, 4): the shape fit's pose grid, then a pattern
    search over the 26 neighbours with a halving step."""
    fam = _resolve_family(shape)
    params = {k: np.array([float(v)]) for k, v in sizes.items()}

    def cost(poses: np.ndarray) -> np.ndarray:
        z = (poses - _LO) / (_HI - _LO)
        predicted = cal.apply(geometric_features(fam.shape, params, poses), shape)
        return _objective(measured, predicted, z, cal)

    grid = _pose_grid()
    c = cost(grid)
    best, best_cost = grid[int(np.argmin(c))], float(c.min())
    step = (_HI - _LO) / (np.array([*OFFSET_STEPS, ROTATION_STEPS]) - 1) / 2.0
    moves = np.stack(np.meshgrid(*[(-1.0, 0.0, 1.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    moves = moves[np.any(moves != 0, axis=1)]
    for _ in range(POSE_ROUNDS):
        cand = np.clip(best + moves * step, _LO, _HI)
        cc = cost(cand)
        j = int(np.argmin(cc))
        if cc[j] < best_cost:
            best, best_cost = cand[j], float(cc[j])
        else:
            step = step / 2.0
    return params, best


def _geometry(measured: np.ndarray, shape: str, sizes, cal: Calibration) -> np.ndarray:
    """(3, 4) geometric features at the sizes and pose that best explain ``measured`` (2, 4)
    with coefficients ``cal``; ``sizes`` None: fitted too."""
    fam = _resolve_family(shape)
    if sizes is None:
        angles = np.stack([measured[0], measured[1], np.zeros(4)])  # J0 read as J2, J1 = 0
        best = fit_shape(angles, [shape], cal).best
        params = {k: np.asarray(v, dtype=float) for k, v in best.params.items()}
        pose = np.array([best.offset[0], best.offset[1], math.radians(best.rotation_deg)])
    else:
        params, pose = _fit_pose(measured, shape, sizes, cal)
        pose = pose[None]
    return np.asarray(geometric_features(fam.shape, params, pose)).reshape(3, 4)


def _regress(geometry: np.ndarray, measured: np.ndarray, start: Calibration, strength: float,
             shapes: Sequence[str] = (), families: Sequence[str] = ()) -> Calibration:  # fmt: skip
    """Ridge regression of measured (n, 2, 4) on geometric (n, 3, 4) toward ``start``; with
    an offset per family of ``families`` (grasps labelled ``shapes``), pulled toward
    ``start``'s (none: 0) ``FAMILY_PULL`` times as hard as the intercepts."""
    out = {k: np.array(getattr(start, k), dtype=float) for k in ("intercept", "gain", "side")}
    labels = np.asarray(shapes, dtype=object)
    family = {n: np.array(start.family.get(n, np.zeros((2, 4))), dtype=float) for n in families}
    for j in range(2):
        for f in range(4):
            ok = geometry[:, 2, f] >= 0  # grasps with the object under this finger
            if not ok.any():
                continue
            g, s = geometry[ok, j, f], np.clip(geometry[ok, 2, f], 0.0, None)
            one_hot = [(labels[ok] == n).astype(float) for n in families]
            x = np.column_stack([np.ones(g.size), g, s, *one_hot])
            prior = np.array([start.intercept[j, f], start.gain[j, f], start.side[j, f],
                              *(family[n][j, f] for n in families)])  # fmt: skip
            # each coefficient's prior weighs ``strength`` grasps' worth of its regressor
            scale = np.array([1.0, GAIN_PULL * max(float(np.mean(g * g)), 1e-6),
                              GAIN_PULL * max(float(np.mean(s * s)), 1e-3),
                              *[FAMILY_PULL] * len(families)])  # fmt: skip
            lam = np.diag(strength * scale)
            theta = np.linalg.solve(x.T @ x + lam, x.T @ measured[ok, j, f] + lam @ prior)
            out["intercept"][j, f], out["gain"][j, f], out["side"][j, f] = theta[:3]
            for n, value in zip(families, theta[3:], strict=True):
                family[n][j, f] = value
    return replace(start, **out, family={**start.family, **family}, source="fitted")


def _spread(geometry: np.ndarray, measured: np.ndarray, shapes: Sequence[str],
            cal: Calibration, start: Calibration) -> np.ndarray:  # fmt: skip
    """(2, 4) sigma from the residuals of ``cal`` on grasps of known sizes, scaled by
    ``SIGMA_INFLATE`` and pooled with ``start``'s sigma worth ``SIGMA_PRIOR`` times the
    grasps."""
    predicted = np.array([cal.apply(g, s) for g, s in zip(geometry, shapes, strict=True)])
    touched = (geometry[:, 2, :] >= 0)[:, None, :]
    squares = np.where(touched, (measured - predicted) ** 2, 0.0).sum(axis=0)
    prior = SIGMA_PRIOR * len(shapes)
    count = touched.sum(axis=0)
    return np.sqrt((SIGMA_INFLATE * squares + prior * start.sigma**2) / (count + prior))


def _alternate(measured, shapes, sizes, start: Calibration, strength: float, first=None,
               per_family: bool = False):  # fmt: skip
    """Coefficients after ``ROUNDS`` alternations; ``first`` the geometry under ``start``
    when already known (every strength and fold shares it). ``per_family``: families whose
    every grasp has known sizes get an offset of their own, and where every grasp has, sigma
    is refitted too."""
    cal = start
    unknown = {s for s, z in zip(shapes, sizes, strict=True) if z is None}
    families = [n for n in dict.fromkeys(shapes) if per_family and n not in unknown]
    for k in range(ROUNDS):
        if k == 0 and first is not None:
            geometry = first
        else:
            rows = zip(measured, shapes, sizes, strict=True)
            geometry = np.array([_geometry(m, s, z, cal) for m, s, z in rows])
        cal = _regress(geometry, measured, start, strength, shapes, families)
    if per_family and all(z is not None for z in sizes):
        cal = replace(cal, sigma=_spread(geometry, measured, shapes, cal, start))
    return cal


def _held_out(measured, shapes, families, cal: Calibration) -> tuple[int, float]:
    """(right answers, summed clipped margin) of ``cal`` on grasps it was not fitted to: the
    margin is how far the best other family's score lies above the labelled one's."""
    right, margin = 0, 0.0
    angles = [np.stack([m[0], m[1], np.zeros(4)]) for m in measured]
    fits = fit_many(angles, families, cal, desc="shape fits (held-out grasps)")
    for fit, s in zip(fits, shapes, strict=True):
        right += fit.shape == s
        other = min(f.score for name, f in fit.fits.items() if name != s)
        margin += float(np.clip(other - fit.fits[s].score, -MARGIN_CLIP, MARGIN_CLIP))
    return right, margin


def _folds(shapes: Sequence[str], folds: int) -> np.ndarray:
    """Fold index of each grasp: the grasps ordered by their rank within their shape, then
    dealt round-robin, so every fold holds a spread of shapes (one grasp per shape too)."""
    seen: dict[str, int] = {}
    rank = []
    for s in shapes:
        rank.append(seen.get(s, 0))
        seen[s] = seen.get(s, 0) + 1
    order = sorted(range(len(shapes)), key=lambda i: (rank[i], shapes[i]))
    out = np.zeros(len(shapes), dtype=int)
    out[order] = np.arange(len(shapes)) % folds
    return out


def check_inputs(angles, shapes, sizes=None) -> None:
    """UsageError for no grasps, a count mismatch, a shape the fit has no model of, or known
    sizes the shape refuses; cheap, so callers run it before any long work."""
    if len(angles) == 0:
        raise UsageError("a hand calibration needs at least one grasp of a known shape")
    if len(angles) != len(shapes):
        raise UsageError(f"{len(angles)} grasps but {len(shapes)} shape labels")
    known = set(fitted_shapes())
    for name in shapes:
        if name not in known:
            raise UsageError(
                f"cannot calibrate on shape {name!r}: the shape fit has no model of it "
                f"(shapes: {', '.join(sorted(known))})"
            )
    if len(set(shapes)) < 2:
        raise UsageError("a hand calibration needs grasps of at least two shapes")
    if sizes is not None:
        if len(sizes) != len(shapes):
            raise UsageError(f"{len(shapes)} grasps but {len(sizes)} entries of known sizes")
        for name, given in zip(shapes, sizes, strict=True):
            if given is not None:
                check_consistent(name, _resolve_family(name).shape.resolve(given))


def fit_hand(
    angles: Sequence[np.ndarray],
    shapes: Sequence[str],
    sizes: Sequence[Mapping[str, float] | None] | None = None,
    start: Calibration | None = None,
    strengths: Sequence[float] = STRENGTHS,
    folds: int = FOLDS,
) -> HandFit:
    """Shape-fit coefficients for the hand that made ``angles`` (each 3 x 4: J3, J2, J1 x
    ff..lf, as ``GraspRecord.fci_angles`` gives them) on objects of known ``shapes``; ``sizes``
    per grasp (a mapping of the shape's parameters, m) where the user knows them, else None.
    Starts from ``start`` (the shipped coefficients by default) and keeps it unless a refit
    does better on held-out calibration grasps."""
    check_inputs(angles, shapes, sizes)
    measured = np.array([measured_features(a) for a in angles])
    shapes = [str(s) for s in shapes]
    resolved = [None if z is None else _resolve_family(s).shape.resolve(z)
                for s, z in zip(shapes, sizes or [None] * len(shapes), strict=True)]  # fmt: skip
    start = load_calibration() if start is None else start
    counts = {s: shapes.count(s) for s in dict.fromkeys(shapes)}
    families = list(counts)
    k = max(2, min(folds, len(shapes)))
    fold = _folds(shapes, k)
    first = np.array([_geometry(m, s, z, start) for m, s, z in zip(measured, shapes, resolved,
                                                                   strict=True)])  # fmt: skip
    rows = []
    # with known sizes each pull is tried with and without family terms (after: a tie keeps
    # the simpler model)
    options = (False, True) if any(z is not None for z in resolved) else (False,)
    candidates = [(None, False)] + [(s, p) for s in strengths for p in options]
    from ..console import tick

    for step, (strength, per_family) in enumerate(candidates):
        tick("calibrate: candidate coefficients tried", step, len(candidates))
        right, margin = 0, 0.0
        for f in range(k):
            train, test = fold != f, fold == f
            if not test.any():
                continue
            cal = start
            if strength is not None and train.any():
                idx = np.flatnonzero(train)
                picked = [shapes[i] for i in idx], [resolved[i] for i in idx]
                pull = strength * len(idx)
                cal = _alternate(measured[idx], *picked, start, pull, first[idx], per_family)
            idx = np.flatnonzero(test)
            r, c = _held_out(measured[idx], [shapes[i] for i in idx], families, cal)
            right, margin = right + r, margin + c
        rows.append({"strength": strength, "family_terms": per_family, "held_out_right": right,
                     "held_out_margin": margin / len(shapes)})  # fmt: skip
    best = rows[0]
    for row in rows[1:]:
        if (row["held_out_right"], row["held_out_margin"]) > (
            best["held_out_right"], best["held_out_margin"]
        ):
            best = row
    strength = best["strength"]
    cal = start
    if strength is not None:
        cal = _alternate(measured, shapes, resolved, start, strength * len(shapes), first,
                         best["family_terms"])  # fmt: skip
    report = {
        "grasps": len(shapes),
        "folds": k,
        "known_sizes": sum(z is not None for z in resolved),
        "candidates": rows,
        "strength": strength,
        "family_terms": best["family_terms"],
        "held_out_accuracy": best["held_out_right"] / len(shapes),
        "start_held_out_accuracy": rows[0]["held_out_right"] / len(shapes),
    }
    return HandFit(replace(cal, source="hand calibration"), strength, counts, report)
