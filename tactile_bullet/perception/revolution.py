"""Is the grasped object a solid of revolution? Its contacts' normals say.

Every normal line of a surface of revolution meets the surface's axis (or runs parallel to it,
on a flat end cap). The five families are solids of revolution; a box, a prism, a bar of soap
or a banana are not, and from the joint angles alone they read as one of the families (three
tangent lines always have a circle tangent to them all: docs/robustness.md, "what limits it").
A simulated grasp knows more than its angles: where each link touches and the object's
outward normal there. :func:`axis_residual` fits the one line that meets every link's normal
line best and returns how far they miss it; :mod:`.contact_check` turns that into ``unknown``
with thresholds set on a model's training grasps.

A record without contacts (a hand's CSV, a real hand) or with fewer than ``MIN_LINKS``
touching links gives no residual, and the check then says nothing.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .robust_lm import minimise

MIN_LINKS = 5
"""Touching links a residual needs: the axis has 4 unknowns."""
LOSS_KNEE = 0.002
"""Soft-L1 knee (m) of the axis fit: one link's odd normal (an edge of a mesh) does not move
the axis much."""
START_TILTS = (-0.4, 0.0, 0.4)
"""Starting tilts of the axis toward the fingers (rad-like slope): the fit's starts."""


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


def fit_axes(points: np.ndarray, normals: np.ndarray, mask: np.ndarray,
             return_axes: bool = False):
    """RMS triple product (m) of the best axis of each grasp (and the axes, (g, 4), with
    ``return_axes``), batched: ``points`` and
    ``normals`` (g, k, 3) padded, ``mask`` (g, k) the real links. Minimises the soft-L1 cost
    of the products (knee ``LOSS_KNEE``) from each of ``START_TILTS`` by Levenberg-Marquardt
    on its reweighted least squares, and keeps the start of lowest cost."""
    g = len(points)
    if g == 0:
        return (np.zeros(0), np.zeros((0, 4))) if return_axes else np.zeros(0)
    w_mask = mask.astype(float)
    n_links = np.maximum(w_mask.sum(axis=1), 1.0)
    mean = (points * w_mask[..., None]).sum(axis=1) / n_links[:, None]
    starts = np.array(START_TILTS)
    theta = np.zeros((g, len(starts), 4))
    theta[..., 1] = starts
    theta[..., 2] = (mean[:, 1] - 0.03)[:, None]
    theta[..., 3] = mean[:, 2][:, None]
    pts, nrm = points[:, None], normals[:, None]
    e_best, axes = minimise(theta, lambda t, _jac: _terms(t, pts, nrm), w_mask[:, None],
                            LOSS_KNEE, ITERATIONS)  # fmt: skip
    rms = np.sqrt((w_mask * e_best**2).sum(axis=1) / n_links)
    return (rms, axes) if return_axes else rms  # axes: (ty, tz, cy, cz) of each best


def padded(arrays: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(g, k, 3) rows of (k_i, 3) arrays padded with zeros to the longest, and the (g, k) mask
    of the real ones: what the batched fits take."""
    k = max(len(a) for a in arrays)
    out = np.zeros((len(arrays), k, 3))
    mask = np.zeros((len(arrays), k), dtype=bool)
    for row, a in enumerate(arrays):
        out[row, : len(a)], mask[row, : len(a)] = a, True
    return out, mask


def axis_fits(records: Sequence) -> tuple[list[float | None], list[np.ndarray | None]]:
    """Each grasp's axis residual (:func:`axis_residuals`) and its best axis (ty, tz, cy, cz),
    both None with fewer than ``MIN_LINKS`` links: the profile fit starts from the axis."""
    parts = [link_contacts(r) for r in records]
    todo = [i for i, (p, _) in enumerate(parts) if len(p) >= MIN_LINKS]
    residuals: list[float | None] = [None] * len(records)
    axes: list[np.ndarray | None] = [None] * len(records)
    if not todo:
        return residuals, axes
    points, mask = padded([parts[i][0] for i in todo])
    normals, _ = padded([parts[i][1] for i in todo])
    rms, best = fit_axes(points, normals, mask, return_axes=True)
    for row, i in enumerate(todo):
        residuals[i], axes[i] = float(rms[row]), best[row]
    return residuals, axes


def axis_residuals(records: Sequence) -> list[float | None]:
    """How far (m, RMS) the normal lines of each grasp's touching links miss the axis that
    fits them best; None with fewer than ``MIN_LINKS`` links (no contacts: a recording)."""
    return axis_fits(records)[0]


def axis_residual(record) -> float | None:
    """:func:`axis_residuals` of one grasp."""
    return axis_residuals([record])[0]
