"""The Levenberg-Marquardt fit that the contact rules share (:mod:`.revolution`'s axis,
:mod:`.profile_fit`'s surfaces): damped, reweighted Gauss-Newton on a soft-L1 loss, batched
over grasps and their starts.

The soft-L1 loss rho(z) = 2 (sqrt(1 + z) - 1) of z = (e / knee)^2 is minimised by least squares
reweighted by 1 / sqrt(1 + z) (its derivative); the damping scales each parameter's own
curvature (Marquardt), with a tiny ridge that keeps a degenerate system (a sphere's axis: any
line through its centre fits) regular.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def soft_l1_cost(e: np.ndarray, mask: np.ndarray, knee: float) -> np.ndarray:
    """Soft-L1 cost of residuals ``e`` (..., k) over the real ones (``mask``, 0 or 1)."""
    return (mask * 2.0 * (np.sqrt(1.0 + (e / knee) ** 2) - 1.0)).sum(axis=-1)


def soft_l1_step(jac: np.ndarray, e: np.ndarray, mask: np.ndarray, knee: float,
                 damping: np.ndarray) -> np.ndarray:  # fmt: skip
    """The parameter step (..., p) from residuals ``e`` (..., k) and their Jacobian
    ``jac`` (..., k, p), with Marquardt ``damping`` (...)."""
    w = mask / np.sqrt(1.0 + (e / knee) ** 2)
    jw = jac * w[..., None]
    a = np.einsum("...ki,...kj->...ij", jw, jac)
    b = -np.einsum("...ki,...k->...i", jw, e)
    scale = np.maximum(np.einsum("...ii->...i", a), 1e-12)
    lhs = a + (damping[..., None, None] * scale[..., None, :] + 1e-12) * np.eye(a.shape[-1])
    return np.linalg.solve(lhs, b[..., None])[..., 0]


def minimise(
    theta: np.ndarray,
    terms: Callable[[np.ndarray, bool], tuple[np.ndarray, np.ndarray | None]],
    mask: np.ndarray,
    knee: float,
    iterations: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Each grasp's best start: ``theta`` (g, starts, p) moved by ``iterations`` steps,
    each taken where it lowers the start's soft-L1 cost (the damping shrinking by 0.3 on a
    success, growing tenfold on a failure). ``terms(theta, jacobian)`` gives the residuals
    (..., k) and, where asked, their Jacobian (..., k, p); the last step's is never asked.
    ``mask`` (g, 1, k) marks the real residuals. Returns the residuals (g, k) and the
    parameters (g, p) of each grasp's start of lowest cost."""
    e, jac = terms(theta, True)
    now = soft_l1_cost(e, mask, knee)
    damping = np.full(theta.shape[:-1], 1e-3)
    for step in range(iterations):
        trial = theta + soft_l1_step(jac, e, mask, knee, damping)
        last = step == iterations - 1
        e_try, jac_try = terms(trial, not last)
        cost = soft_l1_cost(e_try, mask, knee)
        better = np.isfinite(cost) & (cost < now)
        theta = np.where(better[..., None], trial, theta)
        e = np.where(better[..., None], e_try, e)
        if not last:
            jac = np.where(better[..., None, None], jac_try, jac)
        now = np.where(better, cost, now)
        damping = np.where(better, damping * 0.3, damping * 10.0)
    best = np.argmin(now, axis=1)[:, None, None]
    return np.take_along_axis(e, best, axis=1)[:, 0], np.take_along_axis(theta, best, axis=1)[:, 0]
