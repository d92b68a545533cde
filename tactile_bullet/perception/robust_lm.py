"""The damped, reweighted Gauss-Newton step that the contact rules' fits share
(:mod:`.revolution`'s axis, :mod:`.profile_fit`'s surfaces): Levenberg-Marquardt on a soft-L1
loss, batched over any leading axes (grasps, starts).

The soft-L1 loss rho(z) = 2 (sqrt(1 + z) - 1) of z = (e / knee)^2 is minimised by least squares
reweighted by 1 / sqrt(1 + z) (its derivative); the damping scales each parameter's own
curvature (Marquardt), with a tiny ridge that keeps a degenerate system (a sphere's axis: any
line through its centre fits) regular.
"""

from __future__ import annotations

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
