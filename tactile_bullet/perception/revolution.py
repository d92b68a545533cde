"""Is the grasped object a solid of revolution? Its contacts' normals say.

Every normal line of a surface of revolution meets the surface's axis (or runs parallel to it,
on a flat end cap). The five families are solids of revolution; a box, a prism, a bar of soap
or a banana are not, and from the joint angles alone they read as one of the families (three
tangent lines always have a circle tangent to them all: docs/robustness.md, "what limits it").
A simulated grasp knows more than its angles: where each link touches and the object's
outward normal there. :func:`axis_residual` fits the one line that meets every link's normal
line best and returns how far they miss it; :class:`AxisCheck` turns that into ``unknown``
with thresholds set on a model's training grasps.

A record without contacts (a hand's CSV, a real hand) or with fewer than ``MIN_LINKS``
touching links gives no residual, and the check then says nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

MIN_LINKS = 5
"""Touching links a residual needs: the axis has 4 unknowns."""
LOSS_KNEE = 0.002
"""Soft-L1 knee (m) of the axis fit: one link's odd normal (an edge of a mesh) does not move
the axis much."""
START_TILTS = (-0.4, 0.0, 0.4)
"""Starting tilts of the axis toward the fingers (rad-like slope): the fit's starts."""
RATE = 0.025
"""Share of a family's training grasps (per engine) whose residual may exceed its threshold:
with the novelty rule's 5% on held-out folds, the two stay near the 5% in-family budget
(docs/robustness.md, the fourth replicate's declaration)."""
FLOOR = 0.001
"""Least threshold (m): MuJoCo's primitive cylinders and spheres fit to 0.0."""


def link_contacts(record) -> tuple[np.ndarray, np.ndarray]:
    """(points (k, 3), unit normals (k, 3)) of the k links touching the object: each link's
    contact points averaged, its normals summed and normalised. A link whose normals cancel
    is left out."""
    links = np.asarray(getattr(record, "contact_link", ()), dtype=str)
    if links.size == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    position = np.asarray(record.contact_position, dtype=float).reshape(-1, 3)
    normal = np.asarray(record.contact_normal, dtype=float).reshape(-1, 3)
    names, index = np.unique(links, return_inverse=True)
    points = np.zeros((len(names), 3))
    sums = np.zeros((len(names), 3))
    np.add.at(points, index, position)
    np.add.at(sums, index, normal)
    points /= np.bincount(index, minlength=len(names))[:, None]
    length = np.linalg.norm(sums, axis=1)
    keep = length > 1e-9
    return points[keep], sums[keep] / length[keep, None]


ITERATIONS = 60
"""Levenberg-Marquardt steps of the axis fit (it settles in 10-30)."""


def _terms(theta: np.ndarray, points: np.ndarray, normals: np.ndarray):
    """Triple products (p - c) . (n x d) = d . (p x n) - c . (n x d) for axes
    (..., 4) = (ty, tz, cy, cz) through (0, cy, cz) along (1, ty, tz), and their Jacobian.
    ``points``, ``normals``: (..., k, 3)."""
    u = np.stack([np.ones_like(theta[..., 0]), theta[..., 0], theta[..., 1]], axis=-1)
    norm = np.linalg.norm(u, axis=-1, keepdims=True)
    d = u / norm
    c = np.stack([np.zeros_like(theta[..., 2]), theta[..., 2], theta[..., 3]], axis=-1)
    q = np.cross(points - c[..., None, :], normals)  # (..., k, 3)
    e = np.einsum("...j,...kj->...k", d, q)
    grad_u = (q - e[..., None] * d[..., None, :]) / norm[..., None]  # de/du
    nxd = np.cross(normals, d[..., None, :])
    jac = np.stack([grad_u[..., 1], grad_u[..., 2], -nxd[..., 1], -nxd[..., 2]], axis=-1)
    return e, jac


def fit_axes(points: np.ndarray, normals: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """RMS triple product (m) of the best axis of each grasp, batched: ``points`` and
    ``normals`` (g, k, 3) padded, ``mask`` (g, k) the real links. Minimises the soft-L1 cost
    of the products (knee ``LOSS_KNEE``) from each of ``START_TILTS`` by Levenberg-Marquardt
    on its reweighted least squares, and keeps the start of lowest cost."""
    g = len(points)
    if g == 0:
        return np.zeros(0)
    w_mask = mask.astype(float)
    n_links = np.maximum(w_mask.sum(axis=1), 1.0)
    mean = (points * w_mask[..., None]).sum(axis=1) / n_links[:, None]
    starts = np.array(START_TILTS)
    theta = np.zeros((g, len(starts), 4))
    theta[..., 1] = starts
    theta[..., 2] = (mean[:, 1] - 0.03)[:, None]
    theta[..., 3] = mean[:, 2][:, None]
    pts, nrm = points[:, None], normals[:, None]
    wm = w_mask[:, None]

    def cost(e):
        z = (e / LOSS_KNEE) ** 2
        return (wm * 2.0 * (np.sqrt(1.0 + z) - 1.0)).sum(axis=-1)

    damping = np.full(theta.shape[:-1], 1e-3)
    e, jac = _terms(theta, pts, nrm)
    now = cost(e)
    eye = np.eye(4)
    for _ in range(ITERATIONS):
        w = wm / np.sqrt(1.0 + (e / LOSS_KNEE) ** 2)  # IRLS weights of the soft-L1 loss
        jw = jac * w[..., None]
        a = np.einsum("...ki,...kj->...ij", jw, jac)
        b = -np.einsum("...ki,...k->...i", jw, e)
        scale = np.maximum(np.einsum("...ii->...i", a), 1e-12)
        # the ridge keeps a sphere's system regular: any axis through its centre fits
        lhs = a + (damping[..., None, None] * scale[..., None, :] + 1e-12) * eye
        trial = theta + np.linalg.solve(lhs, b[..., None])[..., 0]
        e_try, jac_try = _terms(trial, pts, nrm)
        better = cost(e_try) < now
        theta = np.where(better[..., None], trial, theta)
        e = np.where(better[..., None], e_try, e)
        jac = np.where(better[..., None, None], jac_try, jac)
        now = np.where(better, cost(e_try), now)
        damping = np.where(better, damping * 0.3, damping * 10.0)
    best = np.argmin(now, axis=1)
    e_best = np.take_along_axis(e, best[:, None, None], axis=1)[:, 0]
    return np.sqrt((w_mask * e_best**2).sum(axis=1) / n_links)


def axis_residuals(records: Sequence) -> list[float | None]:
    """How far (m, RMS) the normal lines of each grasp's touching links miss the axis that
    fits them best; None with fewer than ``MIN_LINKS`` links (no contacts: a recording)."""
    parts = [link_contacts(r) for r in records]
    todo = [i for i, (p, _) in enumerate(parts) if len(p) >= MIN_LINKS]
    out: list[float | None] = [None] * len(records)
    if not todo:
        return out
    k = max(len(parts[i][0]) for i in todo)
    points = np.zeros((len(todo), k, 3))
    normals = np.zeros((len(todo), k, 3))
    mask = np.zeros((len(todo), k), dtype=bool)
    for row, i in enumerate(todo):
        p, n = parts[i]
        points[row, : len(p)], normals[row, : len(p)], mask[row, : len(p)] = p, n, True
    for i, value in zip(todo, fit_axes(points, normals, mask), strict=True):
        out[i] = float(value)
    return out


def axis_residual(record) -> float | None:
    """:func:`axis_residuals` of one grasp."""
    return axis_residuals([record])[0]


def _engine(record) -> str:
    controller = getattr(record, "controller", None)
    return str(getattr(controller, "engine", None) or "bullet")


@dataclass(frozen=True)
class AxisCheck:
    """Thresholds on the axis residual, per engine and family: above the one of the family an
    answer names, the grasp is no solid of revolution and the answer is ``unknown``."""

    thresholds: Mapping[str, Mapping[str, float]]
    """engine -> family -> threshold (m)."""
    rate: float = RATE
    grasps: int = 0
    """Distinct training grasps the thresholds were set on."""

    @classmethod
    def fit(
        cls, records: Sequence, labels: Sequence[str], groups: np.ndarray | None = None,
        rate: float = RATE, residuals: Callable[[Sequence], list] | None = None,
    ) -> AxisCheck | None:  # fmt: skip
        """Thresholds from training grasps (``groups``: copies of one grasp, residual taken
        once; ``residuals``: :func:`axis_residuals` or a cached form of it); None where no
        family on any engine has 20 grasps with a residual."""
        keep, seen = [], set()
        for i in range(len(records)):
            group = i if groups is None else int(groups[i])
            if group not in seen:
                seen.add(group)
                keep.append(i)
        distinct = [records[i] for i in keep]
        values: dict[tuple[str, str], list[float]] = {}
        for i, value in zip(keep, (residuals or axis_residuals)(distinct), strict=True):
            if value is not None:
                values.setdefault((_engine(records[i]), str(labels[i])), []).append(value)
        thresholds: dict[str, dict[str, float]] = {}
        for (engine, label), v in values.items():
            if len(v) >= 20:
                q = float(np.quantile(v, 1.0 - rate, method="higher"))
                thresholds.setdefault(engine, {})[label] = max(q, FLOOR)
        if not thresholds:
            return None
        return cls(thresholds, rate, sum(len(v) for v in values.values()))

    def threshold(self, engine: str, family: str) -> float | None:
        """The engine's threshold for ``family``, else the largest any engine has for it."""
        own = self.thresholds.get(engine, {}).get(family)
        if own is not None:
            return own
        others = [t[family] for t in self.thresholds.values() if family in t]
        return max(others) if others else None

    def residuals(self, records: Sequence) -> list[float | None]:
        return axis_residuals(records)

    def unknown(self, records: Sequence, names: Sequence[str],
                residuals: Sequence[float | None] | None = None) -> np.ndarray:  # fmt: skip
        """Which answers the check makes ``unknown`` (False where it has no residual or no
        threshold for the named family)."""
        residuals = self.residuals(records) if residuals is None else residuals
        out = np.zeros(len(records), dtype=bool)
        for i, (record, name, residual) in enumerate(zip(records, names, residuals, strict=True)):
            limit = self.threshold(_engine(record), str(name))
            out[i] = residual is not None and limit is not None and residual > limit
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"thresholds": {e: dict(t) for e, t in self.thresholds.items()},
                "rate": self.rate, "grasps": self.grasps}  # fmt: skip

    @classmethod
    def from_dict(cls, doc: Any) -> AxisCheck:
        """The check a model file keeps; ValueError naming what is wrong with a damaged one."""
        if not isinstance(doc, Mapping) or not isinstance(doc.get("thresholds"), Mapping):
            raise ValueError("its axis check has no thresholds")
        thresholds: dict[str, dict[str, float]] = {}
        for engine, table in doc["thresholds"].items():
            if not isinstance(table, Mapping):
                raise ValueError(f"its axis check's {engine!r} thresholds are not a table")
            for family, value in table.items():
                if isinstance(value, bool) or not isinstance(value, int | float) or \
                        not np.isfinite(value) or value <= 0:  # fmt: skip
                    raise ValueError(f"its axis check's threshold {engine}/{family} is not a "
                                     "positive number")  # fmt: skip
                thresholds.setdefault(str(engine), {})[str(family)] = float(value)
        rate, grasps = doc.get("rate", RATE), doc.get("grasps", 0)
        if not isinstance(rate, int | float) or not 0 < rate < 1:
            raise ValueError("its axis check's rate is not in (0, 1)")
        return cls(thresholds, float(rate), int(grasps) if isinstance(grasps, int) else 0)
