"""Training-free identification by fitting each shape family to the absolute joint angles.

The signature (``perception/signature.py``) normalises each line, which is what makes the
thesis' DTW matcher size-invariant, and also what makes a sphere look like a torus and a
cylinder like a hyperboloid: their enhanced lines differ only in scale and in curvature the
hand barely feels.
This module keeps the scale. For every shape family it searches the sizes and the object's
position (offset along O-O' and along the fingers) whose *predicted* final joint angles best
explain the measured ones, and names the family with the best penalised fit. It also returns
the fitted sizes, which the DTW matcher cannot.

The forward model (what Algorithm 1's joints end at on a known object) and its calibration
live in :mod:`~tactile_bullet.perception.shape_model`.

Identification: for each family, a precomputed grid of sizes x offsets (predicted angles
computed once and kept on disk by :mod:`~tactile_bullet.perception.grid_cache`), then, for
the families whose grid score is near the best, a batched pattern search around the best grid
point and a few damped Gauss-Newton steps. The score is the robust (soft-L1) sum of weighted
residuals plus a penalty per size parameter; the lowest score wins.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from functools import cache

import numpy as np

from ..errors import UsageError
from ..objects.shapes import BUILTIN_SHAPES, THESIS_SHAPES, Shape, check_consistent
from .family_fit import FamilyFit, ShapeFit, measured_features
from .fit_cache import cached_answer, cached_fit, keep_fit, keep_name
from .grid_cache import grid_geometry
from .search_steps import damped_steps, unique_rows
from .shape_model import (
    _XF,
    Calibration,
    _chain_features,
    _reach,
    _sections,
    active_calibration,
    geometric_features,
    nominal_centre,
)

OFFSET_X = (-0.02, 0.02)
"""Range (m) searched for the object's offset along O-O' (twice the thesis preset's)."""

OFFSET_Z = (-0.015, 0.015)
"""Range (m) searched for the object's offset along the fingers."""

ROTATION = (-math.radians(30.0), math.radians(30.0))
"""Range (rad) searched for the object's rotation about the palm normal (``Pose.rotation``)."""

FEATURES = ("J3", "J0")
"""Per finger, what is fitted: the proximal angle and the coupled J0 = J1 + J2 (the split of
J0 between J1 and J2 follows the tendon rule, not the shape)."""

GRID_STEPS = {1: 22, 2: 10, 3: 6}
"""Grid values per size parameter, by the family's number of parameters. The counts avoid
putting grid points on quarters of the ranges (other than the ends), where
``tools/invariance.py`` places its evaluation sizes: the search starts no closer to the truth
there than anywhere else."""

OFFSET_STEPS = (8, 6)
"""Grid values of the offset along O-O' and along the fingers (none at 0 or +-10 mm, the
evaluation grid's offsets)."""

ROTATION_PRIOR_DEG = 15.0
"""Spread of the zero-mean Gaussian prior on the rotation, added to the score as
(rotation / spread)**2 (the data term is a sum of squared sigmas too). Without it a cylinder
at an outer offset is explained as well by a cone turned 20 deg: turning a cylinder moves each
finger's section up or down the knuckle's tangent, as a cone's taper does, and eight angles
cannot always tell the two apart. Most grasps are near square; a turn must earn its cost."""

STARTS = 3
"""Grid points per family the pattern search starts from, each the best of its grid rotation:
with the rotation in the grid, the single best point often lies in another valley (a turned,
larger object further out)."""

ROTATION_STEPS = 5
"""Grid values of the rotation: -30, -15, 0, 15, 30 deg. Unlike the sizes and offsets, the
grid keeps 0: most grasps are square, and on a small object one grid step of rotation costs
more than the search can walk back."""

REFINE_ROUNDS = 3
"""Moves or halvings of the pattern search's step after the grid."""

REFINE_MARGIN = 25.0
"""Families whose grid score is more than this above the best grid score keep their grid fit:
refining them costs time and cannot bring them level."""

_TABLE = {s.name: s for s in BUILTIN_SHAPES}
# --- fitting ----------------------------------------------------------------------------------


def _clip01(z: np.ndarray) -> np.ndarray:
    """``np.clip(z, 0, 1)`` without its Python overhead (the same values, NaN kept)."""
    return np.minimum(np.maximum(z, 0.0), 1.0)


_POSE_LO = (OFFSET_X[0], OFFSET_Z[0], ROTATION[0])
_POSE_HI = (OFFSET_X[1], OFFSET_Z[1], ROTATION[1])
_GRID_CHUNK = 8192


class _Family:
    """One shape family's search space: sizes, offsets and rotation, normalised to [0, 1]."""

    def __init__(self, shape: Shape) -> None:
        self.shape = shape
        self.names = tuple(shape.params)
        self.lo = np.array([shape.params[k].min for k in self.names] + list(_POSE_LO))
        self.hi = np.array([shape.params[k].max for k in self.names] + list(_POSE_HI))
        steps = GRID_STEPS.get(len(self.names), 6)
        axes = [np.linspace(0.0, 1.0, steps)] * len(self.names)
        axes += [np.linspace(0.0, 1.0, n) for n in (*OFFSET_STEPS, ROTATION_STEPS)]
        self.spacing = np.array([1.0 / (len(a) - 1) for a in axes])
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))
        self.grid = grid[self.valid(grid)]
        self.rotation_groups = [
            np.flatnonzero(self.grid[:, -1] == v) for v in np.unique(self.grid[:, -1])
        ]
        self.grid_geometry = grid_geometry(shape.name, self.grid, self._grid_geometry)
        self._cal: Calibration | None = None
        self._pred = self.grid_geometry[..., :2, :]
        self._scaled: tuple | None = None
        self._grid_prior = _prior_residual(self.grid) ** 2
        # the validity of a grid point does not depend on its rotation, the grid's last and
        # fastest axis: the rotation groups are then the columns of the costs reshaped
        rots, cols = self.grid[:, -1], len(self.rotation_groups)
        fastest = len(rots) % cols == 0 and np.array_equal(
            rots.reshape(-1, cols), np.broadcast_to(np.unique(rots), (len(rots) // cols, cols))
        )
        self._rotation_columns = cols if fastest else 0

    def _grid_geometry(self, grid: np.ndarray) -> np.ndarray:
        return np.concatenate(
            [self.geometry(grid[i : i + _GRID_CHUNK]) for i in range(0, len(grid), _GRID_CHUNK)]
        )

    def starts(self, cost: np.ndarray) -> np.ndarray:
        """Grid indices the search starts from: the best point of each grid rotation, the
        ``STARTS`` best of those (the best points overall tend to share one valley)."""
        cols = self._rotation_columns
        if cols:
            best = list(np.argmin(cost.reshape(-1, cols), axis=0) * cols + np.arange(cols))
        else:
            best = [group[np.argmin(cost[group])] for group in self.rotation_groups]
        return np.array(sorted(best, key=lambda i: cost[i])[:STARTS])

    def grid_costs(self, measured: np.ndarray, cal: Calibration) -> np.ndarray:
        """:func:`_objective` over the whole grid in single precision, from predictions kept
        divided by sigma and the loss scale: one subtraction, square and root per angle. Used
        to pick the search's starts only (within ~1e-4 of a score; the starts' own costs are
        then computed in double precision)."""
        if self._scaled is None or self._scaled[0] is not cal:
            scale = cal.sigma * cal.loss_scale
            pred = self.grid_prediction(cal)
            scaled = (pred / scale).reshape(len(pred), -1).astype(np.float32)
            self._scaled = (cal, scaled, scale.ravel(), np.ones(scaled.shape[1], np.float32))
        _, scaled, scale, ones = self._scaled
        e = scaled - (measured.ravel() / scale).astype(np.float32)
        np.square(e, out=e)
        e += 1.0
        np.sqrt(e, out=e)
        c = cal.loss_scale
        return 2.0 * c * c * (e @ ones - e.shape[1]) + self._grid_prior

    def grid_prediction(self, cal: Calibration) -> np.ndarray:
        """The grid's predicted angles under ``cal`` (kept for the last calibration used)."""
        if self._cal is not cal:
            self._cal, self._pred = cal, cal.apply(self.grid_geometry, self.shape.name)
        return self._pred

    def values(self, z: np.ndarray) -> np.ndarray:
        return self.lo + _clip01(z) * (self.hi - self.lo)

    def valid(self, z: np.ndarray) -> np.ndarray:
        v = self.values(z)
        p = {k: v[:, i] for i, k in enumerate(self.names)}
        ok = np.ones(len(z), dtype=bool)
        if self.shape.name == "torus":
            ok &= p["major_radius"] > p["minor_radius"]
        if self.shape.name == "hyperboloid":
            ok &= p["end_radius"] > p["waist_radius"] * 1.001
        return ok

    def sections(self, z: np.ndarray) -> tuple[np.ndarray, ...]:
        v = self.values(z)
        params = {k: v[:, i] for i, k in enumerate(self.names)}
        return _sections(self.shape, params, v[:, -3:])

    def geometry(self, z: np.ndarray) -> np.ndarray:
        return _chain_features(*self.sections(z))


@cache
def _family(name: str) -> _Family:
    return _Family(_TABLE[name])


def fitted_shapes() -> tuple[str, ...]:
    """Shapes the forward model covers (every built-in shape: each has a radius profile)."""
    return tuple(_TABLE)


def _resolve_family(shape: str | Shape) -> _Family:
    name = shape.name if isinstance(shape, Shape) else shape
    if name not in _TABLE:
        raise UsageError(f"shape-fit has no model of shape {name!r} (shapes: {', '.join(_TABLE)})")
    return _family(name)


def _costs(measured: np.ndarray, predicted: np.ndarray, cal: Calibration) -> np.ndarray:
    """Robust (soft-L1) cost of each predicted (.., 2, 4) against the measured (2, 4)."""
    e = (measured - predicted) / cal.sigma
    c = cal.loss_scale
    return (2.0 * c * c * (np.sqrt(1.0 + (e / c) ** 2) - 1.0)).sum(axis=(-2, -1))


def fit_family(angles, shape: str | Shape, calibration: Calibration | None = None) -> FamilyFit:
    """Sizes and offset of ``shape`` that best explain final angles (3, 4): grid, then a
    batched pattern search (every neighbour at +-step in the normalised coordinates, the step
    halved when no move helps)."""
    measured = measured_features(angles)
    cal = active_calibration() if calibration is None else calibration
    fam = _resolve_family(shape)
    return _fit(measured, [fam], cal)[fam.shape.name]


@cache
def _moves(dims: int) -> np.ndarray:
    """Every neighbour at -1, 0, +1 step per coordinate (3**dims - 1 of them): size and
    position trade off along diagonals (a larger object further out), which moves along one
    axis at a time cannot follow."""
    grid = np.stack(np.meshgrid(*[(-1.0, 0.0, 1.0)] * dims, indexing="ij"), -1)
    moves = grid.reshape(-1, dims)
    return moves[np.any(moves != 0, axis=1)]


_ROTATION_SPAN = ROTATION[1] - ROTATION[0]


def _prior_residual(z: np.ndarray) -> np.ndarray:
    """rotation / prior spread of normalised points (..., dims), rotation last: the prior's
    score is its square."""
    beta = ROTATION[0] + _clip01(z[..., -1]) * _ROTATION_SPAN
    return beta / math.radians(ROTATION_PRIOR_DEG)


def _objective(measured: np.ndarray, predicted: np.ndarray, z: np.ndarray, cal) -> np.ndarray:
    """What the search minimises: the robust angle cost plus the rotation prior."""
    return _costs(measured, predicted, cal) + _prior_residual(z) ** 2


def _accept(
    measured: np.ndarray, state: list, trials: list, cal: Calibration, preds=None
) -> dict[int, int]:
    """Score each (start index, candidates) of ``trials`` in one pass of the finger chain (or
    from their predictions ``preds``, given) and move each start to its best candidate where
    that improves on it; returns {start: the candidate it moved to}."""
    moved = {}
    preds = _predict(state, trials, cal) if preds is None else preds
    pred_of = {k: p for (k, _), p in zip(trials, preds, strict=True)}
    rotations = np.concatenate([c[:, -1:] for _, c in trials])  # all the prior reads
    costs = _objective(measured, np.concatenate(preds), rotations, cal)
    at = 0
    for k, cand in trials:
        c = costs[at : at + len(cand)]
        at += len(cand)
        j = int(np.argmin(c))
        if c[j] < state[k][2]:
            state[k][1], state[k][2], state[k][5] = cand[j], float(c[j]), pred_of[k][j]
            moved[k] = j
    return moved


def _fit(measured: np.ndarray, fams: Sequence[_Family], cal: Calibration) -> dict[str, FamilyFit]:
    """Every family's fit at once: the pattern search runs the families (each from its
    ``STARTS`` best grid points) in lockstep so that each round is one pass of the finger chain
    over all their candidates."""
    return _refined(measured, *_grid_stage(measured, fams, cal), cal)


def _grid_stage(measured: np.ndarray, fams: Sequence[_Family], cal: Calibration) -> tuple:
    """The search's starts, each [family, point, cost, step, moves, prediction] with its cost
    as the search computes every later point's, and the indices of those near enough to the
    best to be refined (:data:`REFINE_MARGIN`)."""
    state = []
    for fam in fams:
        starts = fam.starts(fam.grid_costs(measured, cal))
        # the starts' costs exactly as the search computes every later point's
        pred = fam.grid_prediction(cal)[starts]
        exact = _objective(measured, pred, fam.grid[starts], cal)
        dims = fam.grid.shape[1]
        for best, cost, p in zip(starts, exact, pred, strict=True):
            state.append([fam, fam.grid[best], float(cost), fam.spacing / 2.0, _moves(dims), p])
    # only starts whose grid score is near the best one's are worth refining
    scores = [e[2] + cal.penalty * len(e[0].names) for e in state]
    near = [k for k, sc in enumerate(scores) if sc <= min(scores) + REFINE_MARGIN]
    return state, near


def _refined(measured: np.ndarray, state: list, near: list[int], cal: Calibration) -> dict:
    """Each family's fit from the grid stage's starts: the ``near`` ones refined (pattern
    search, then :func:`_polish`), the others kept at their grid point."""
    for _ in range(REFINE_ROUNDS):
        parts = []
        for k in near:
            fam, z, _, step, moves, _ = state[k]
            cand = _clip01(z + moves * step)
            cand = cand[fam.valid(cand)]
            if cand.size:
                parts.append((k, cand))
        if not parts:
            break
        moved = _accept(measured, state, parts, cal)
        for k, _ in parts:
            if k not in moved:
                state[k][3] = state[k][3] / 2.0
    _polish(measured, state, near, cal)
    best_of: dict[str, list] = {}
    for entry in state:
        name = entry[0].shape.name
        if name not in best_of or entry[2] < best_of[name][2]:
            best_of[name] = entry
    out = {}
    for fam, z, cost, _, _, predicted in best_of.values():  # each point's prediction as scored
        values = fam.values(z[None])[0]
        out[fam.shape.name] = FamilyFit(
            shape=fam.shape.name,
            params={k: float(values[i]) for i, k in enumerate(fam.names)},
            offset=(float(values[-3]), float(values[-2])),
            rotation_deg=float(np.degrees(values[-1])),
            residual=float(np.sqrt(np.mean((measured - predicted) ** 2))),
            score=cost + cal.penalty * len(fam.names),
            predicted=predicted,
        )
    return out


def _predict(state, parts, cal: Calibration) -> list[np.ndarray]:
    """Predicted (n, 2, 4) angles of each (family index, candidates) in ``parts``, through one
    pass of the finger chain over all of them: the candidates of every family together, each
    distinct (sizes, offset along O-O', rotation) once (:func:`_shared_sections`)."""
    by_family: dict[_Family, list[int]] = {}
    for i, (k, _) in enumerate(parts):
        by_family.setdefault(state[k][0], []).append(i)
    groups = [(fam, np.concatenate([parts[i][1] for i in idx])) for fam, idx in by_family.items()]
    geometry = _chain_features(*_shared_sections(groups))
    at, out = 0, [None] * len(parts)
    for (fam, z), idx in zip(groups, by_family.values(), strict=True):
        pred = cal.apply(geometry[at : at + len(z)], fam.shape.name)
        at += len(z)
        for i in idx:
            out[i], pred = pred[: len(parts[i][1])], pred[len(parts[i][1]) :]
    return out


def _shared_sections(groups: Sequence[tuple[_Family, np.ndarray]]) -> tuple[np.ndarray, ...]:
    """:func:`~.shape_model._sections` of every (family, points (n, dims)) in ``groups``,
    concatenated: the sections of each distinct (sizes, offset along O-O', rotation) computed
    once (the search's neighbours differ in the offset along the fingers in threes, and that
    offset only shifts the section's centre), and the capsules' reach of all families in one
    batch (each family's radius profile on its own rows)."""
    values, inverses, firsts, y0s, spans = [], [], [], [], []
    at = 0
    for fam, z in groups:
        key = np.delete(z, -2, axis=1)
        first, inverse = unique_rows(key)
        v = fam.values(z)
        u = v[first]
        params = {k: u[:, i] for i, k in enumerate(fam.names)}
        # the nominal centre depends on the sizes and the rotation alone
        sized = np.delete(key, -2, axis=1)[first]
        once, again = unique_rows(sized)
        y0, z0 = nominal_centre(fam.shape, {k: p[once] for k, p in params.items()}, u[once, -1])
        y0 = y0[again.ravel()]
        values.append(v[:, -2:-1])
        firsts.append(u)
        inverses.append(inverse.ravel() + at)
        y0s.append(y0)
        spans.append((fam, at, at + len(first), params))
        at += len(first)
    pose = np.concatenate([u[:, -3:] for u in firsts])

    def radius(u: np.ndarray) -> np.ndarray:
        return np.concatenate([
            fam.shape.radius(u[a:b], **{k: v[:, None, None, None] for k, v in params.items()})
            for fam, a, b, params in spans
        ])  # fmt: skip

    reach, side, rise = _reach(radius, _XF - pose[:, 0:1], pose[:, 2:3])
    inverse = np.concatenate(inverses)
    dz = np.concatenate(values)
    y0 = np.concatenate(y0s)[:, None]
    return reach[inverse], side[inverse], y0[inverse], z0 + dz + rise[inverse]


POLISH_STEPS = 4
"""Levenberg-Marquardt steps after the pattern search: size and position trade off along
curved valleys (a larger object further out) that fixed-ratio steps crawl along."""

_DAMPING = (1e-3, 1e-1, 1e1)


def _fd_points(z: np.ndarray, h: float) -> np.ndarray:
    """A point and its finite-difference neighbours, one step ``h`` along each coordinate."""
    return _clip01(np.vstack([z, z + h * np.eye(z.size)]))


def _polish(measured: np.ndarray, state: list, near: list[int], cal: Calibration) -> None:
    """Damped Gauss-Newton on the soft-L1 cost (reweighted least squares), the near families
    in lockstep. Each step's trial points are evaluated with their own finite-difference
    neighbours, so the next step's Jacobian, around whichever trial a start moved to, is at
    hand: one pass of the finger chain per step."""
    h = 1e-3
    parts = [(k, _fd_points(state[k][1], h)) for k in near]
    fd = dict(zip(near, _predict(state, parts, cal), strict=True))
    for step in range(POLISH_STEPS):
        trials = _polish_trials(measured, state, near, fd, h, cal)
        if not trials:
            return
        if step == POLISH_STEPS - 1:  # no next Jacobian: the trials alone
            _accept(measured, state, trials, cal)
            return
        blocks = [(k, np.concatenate([_fd_points(c, h) for c in cand])) for k, cand in trials]
        block_preds = _predict(state, blocks, cal)
        preds = [p[:: len(c[0]) + 1] for p, (_, c) in zip(block_preds, trials, strict=True)]
        moved = _accept(measured, state, trials, cal, preds)
        for (k, cand), p in zip(trials, block_preds, strict=True):
            if k in moved:
                n = len(cand[0]) + 1
                fd[k] = p[moved[k] * n : (moved[k] + 1) * n]


def _polish_trials(measured, state, near, fd, h, cal) -> list:
    """One damped Gauss-Newton step of each near start from its point's finite differences
    ``fd`` (predictions at the point and at +h along each coordinate): (start, trial points)."""
    sigma = cal.sigma
    by_dims: dict[int, list[int]] = {}
    for k in near:
        by_dims.setdefault(state[k][1].size, []).append(k)
    trials = []
    for dims, members in by_dims.items():
        pred = np.stack([fd[k] for k in members])  # (S, dims + 1, 2, 4)
        pts = np.stack([_fd_points(state[k][1], h) for k in members])  # (S, dims + 1, dims)
        n = len(members)
        e = ((measured - pred[:, 0]) / sigma).reshape(n, -1)
        jac = (-(pred[:, 1:] - pred[:, :1]) / sigma).reshape(n, dims, -1).transpose(0, 2, 1)
        jac = jac / np.maximum(pts[:, 1:] - pts[:, :1], 1e-12).sum(axis=2)[:, None, :]
        w = 1.0 / np.sqrt(1.0 + (e / cal.loss_scale) ** 2)
        # the rotation prior as one more (unweighted) residual, linear in z
        prior_row = np.zeros(dims)
        prior_row[-1] = _ROTATION_SPAN / math.radians(ROTATION_PRIOR_DEG)
        e = np.concatenate([e, _prior_residual(pts[:, 0])[:, None]], axis=1)
        jac = np.concatenate([jac, np.broadcast_to(prior_row, (n, 1, dims))], axis=1)
        w = np.concatenate([w, np.ones((n, 1))], axis=1)
        systems, rhs = [], []
        for j in range(n):  # each start's normal equations as one 2-D product
            jj, wj = jac[j], w[j]
            a = jj.T @ (wj[:, None] * jj)
            g = jj.T @ (wj * e[j])
            for lam in _DAMPING:
                systems.append(a + lam * (np.diag(np.diag(a)) + 1e-9 * np.eye(len(g))))
                rhs.append(g)
        steps = damped_steps(np.stack(systems), np.stack(rhs)).reshape(n, len(_DAMPING), dims)
        for j, k in enumerate(members):
            ok = ~np.isnan(steps[j, :, 0])
            if not ok.any():
                continue
            cand = _clip01(pts[j, 0] + steps[j, ok])
            cand = cand[state[k][0].valid(cand)]
            if cand.size:
                trials.append((k, cand))
    trials.sort(key=lambda t: near.index(t[0]))  # the order the starts were searched in
    return trials


def fit_shape(
    angles,
    families: Sequence[str] = THESIS_SHAPES,
    calibration: Calibration | None = None,
) -> ShapeFit:
    """Fit every family in ``families`` to final angles (3, 4) and name the best-scoring one.

    The second training-free identifier next to ``patterns.identify`` (DTW on the normalised
    signature): it reads absolute angles, so scale separates sphere from torus and cylinder
    from hyperboloid, and a finger that closed to its limits is explained by the model.
    """
    measured, names, cal = _inputs(angles, families, calibration)
    hit = cached_fit(measured, names, cal, features=True)
    if hit is not None:
        return hit
    return _kept(measured, names, cal, _fit(measured, [_resolve_family(n) for n in names], cal))


def _inputs(angles, families: Sequence[str], calibration: Calibration | None) -> tuple:
    """(measured features, the families once each, the coefficients) of a fit, checked."""
    measured = measured_features(angles)
    names = list(dict.fromkeys(families))
    if not names:
        raise UsageError("shape-fit needs at least one shape family")
    return measured, names, active_calibration() if calibration is None else calibration


def _kept(measured, names: list[str], cal: Calibration, fits: dict) -> ShapeFit:
    """The whole fit of every family, named by the best score, kept in the fit cache."""
    out = ShapeFit(min(fits, key=lambda n: fits[n].score), fits)
    return keep_fit(measured, names, cal, out, features=True)


def name_or_fit(
    angles,
    families: Sequence[str] = THESIS_SHAPES,
    calibration: Calibration | None = None,
) -> str | ShapeFit:
    """The family :func:`fit_shape` names for final angles (3, 4), where only that is asked
    (the doubt's cross-check): the family's name where the grid stage decides it, else the
    whole fit (kept, as :func:`fit_shape` keeps it).

    The grid decides it where every start near enough to the best to be refined is of one
    family: the search only lowers the scores it refines, and every other family's score is
    already more than :data:`REFINE_MARGIN` above that family's, so :func:`fit_shape` names
    that family too, whatever the search finds. Its sizes, which the refining is for, are
    then not computed (how often, and what it saves: docs/performance.md, "The cross-check
    reads the family only").
    """
    measured, names, cal = _inputs(angles, families, calibration)
    known = cached_answer(measured, names, cal, features=True)
    if known is not None:
        return known
    state, near = _grid_stage(measured, [_resolve_family(n) for n in names], cal)
    decided = {state[k][0].shape.name for k in near}
    if len(decided) == 1:
        return keep_name(measured, names, cal, decided.pop(), features=True)
    return _kept(measured, names, cal, _refined(measured, state, near, cal))


def predicted_angles(
    shape: str | Shape,
    params: Mapping[str, float] | None = None,
    offset: tuple[float, float] = (0.0, 0.0),
    calibration: Calibration | None = None,
    rotation_deg: float = 0.0,
) -> np.ndarray:
    """(2, 4) J3 and J0 per long finger the model predicts for ``shape`` at sizes ``params``
    (defaults filled in, range-checked), ``offset`` (m, along O-O' and along the fingers) and
    ``rotation_deg`` about the palm normal (within the searched +-30 deg)."""
    fam = _resolve_family(shape)
    values = fam.shape.resolve(params)
    check_consistent(fam.shape.name, values)
    off = np.asarray(offset, dtype=float)
    if off.shape != (2,) or not np.all(np.isfinite(off)):
        raise UsageError("offset must be two finite numbers (m): along O-O', along the fingers")
    beta = math.radians(float(rotation_deg))
    if not (ROTATION[0] - 1e-9 <= beta <= ROTATION[1] + 1e-9):
        raise UsageError(
            f"rotation must be within +-{math.degrees(ROTATION[1]):g} deg, got {rotation_deg}"
        )
    cal = active_calibration() if calibration is None else calibration
    pose = np.array([[off[0], off[1], beta]])
    geo = geometric_features(fam.shape, {k: np.array([v]) for k, v in values.items()}, pose)
    return cal.apply(geo, fam.shape.name)[0]


def shape_fit_summary(record) -> dict | None:
    """The ``shape_fit`` block of ``grasp --json`` for one record ({"shape", "params",
    "offset_m", "residual", "scores"}), or None where its angles cannot be fitted or the grasp
    touched too little (``contact.nothing_to_identify``: the angles of fingers that closed on
    air would still fit some family best, and a shape name there would be a guess). Read with
    the coefficients in force (``grasp`` puts our MuJoCo hand's own in force for its grasps,
    as the doubt's cross-check reads them)."""
    from ..learn.robust import angles_for_shape_fit
    from .contact import nothing_to_identify

    if nothing_to_identify(record) is not None:
        return None
    try:
        return fit_shape(angles_for_shape_fit(record)).summary()
    except UsageError:
        return None
