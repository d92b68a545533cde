"""Where the shape fit's forward model misses another hand: residuals at the true sizes and poses.

For a simulated set (its records know each object's sizes and pose), regress each finger's
measured J3 and J0 = J1 + J2 on the geometric prediction at the true sizes and pose (the best
that one set of the 24 per-finger coefficients can do on that hand, what ``calibrate`` aims
at), then print what is left: the residual spread per finger, its mean per shape family, and
its mean by where the pad meets the section (the sideways fraction, 0 in the finger's plane,
1 at the capsule's side) and by the profile's slope |dr/dx| under the finger. A miss that
depends on the family or on the contact's place, not on the finger, is one the linear
correction cannot take up (docs/calibration.md, "Why MuJoCo stays under 97%").

With ``--oracle`` it also splits each shape's grasps as ``benchmarks/hand_calibration.py`` does
(first half: pool, rest: test), regresses the coefficients on the pool at the true sizes and
poses, and prints the test accuracy of one set of coefficients, of those plus a J3 and J0
offset per family (each family's mean residual on the pool), and of those with each angle's
sigma set to the pool's within-family residual spread: what per-family terms can give where
the sizes are known (~1 min).

Usage: python benchmarks/calibration_residuals.py --data DIR [--oracle]   (DIR e.g.
benchmarks/other_hand_sets.py's)
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments.workflow import records_from
from tactile_bullet.hand import FINGER_X, LONG_FINGERS
from tactile_bullet.perception.shape_fit import _TABLE, measured_features
from tactile_bullet.perception.shape_model import Calibration, geometric_features

SLOPES = (0.0, 0.2, 0.5, 1.0, 2.0, np.inf)


def oracle(geometry: np.ndarray, measured: np.ndarray) -> Calibration:
    """Least squares of measured on (1, geometric, sideways) per finger and joint group."""
    coef = {k: np.zeros((2, 4)) for k in ("intercept", "gain", "side")}
    for j in range(2):
        for f in range(4):
            ok = geometry[:, 2, f] >= 0
            x = np.column_stack([np.ones(ok.sum()), geometry[ok, j, f], geometry[ok, 2, f]])
            theta, *_ = np.linalg.lstsq(x, measured[ok, j, f], rcond=None)
            coef["intercept"][j, f], coef["gain"][j, f], coef["side"][j, f] = theta
    return Calibration(**coef)


def features(records) -> tuple[np.ndarray, np.ndarray]:
    """(geometric features at the true sizes and poses, measured J3 and J0) of ``records``."""
    geometry = np.array([
        geometric_features(_TABLE[r.shape], {k: np.array([v]) for k, v in r.params.items()},
                           np.array([[r.pose.offset[0], r.pose.offset[2], r.pose.rotation]]))[0]
        for r in records
    ])  # fmt: skip
    return geometry, np.array([measured_features(r.fci_angles()) for r in records])


def oracle_accuracies(records) -> None:
    """Test accuracy of coefficients fitted on the pool at the true sizes (module doc)."""
    from dataclasses import replace

    from tactile_bullet.perception.shape_fit import fit_family
    from tactile_bullet.perception.shape_model import load_calibration

    families = sorted({r.shape for r in records})
    by_shape = {s: [r for r in records if r.shape == s] for s in families}
    pool = [r for v in by_shape.values() for r in v[: len(v) // 2]]
    test = [r for v in by_shape.values() for r in v[len(v) // 2 :]]
    geometry, measured = features(pool)
    fitted = oracle(geometry, measured)
    one = replace(load_calibration(), intercept=fitted.intercept, gain=fitted.gain,
                  side=fitted.side)  # fmt: skip
    labels = np.array([r.shape for r in pool])
    res = measured - one.apply(geometry)
    offsets = {s: res[labels == s].mean(axis=0) for s in families}
    within = np.concatenate([res[labels == s] - offsets[s] for s in families])
    per_family = replace(one, family=offsets)
    spread = replace(per_family, sigma=np.maximum(within.std(axis=0), 0.005))
    for name, cal in (("one set of coefficients", one), ("+ an offset per family", per_family),
                      ("+ within-family sigma", spread)):  # fmt: skip
        right = 0
        for r in test:
            scores = {s: fit_family(r.fci_angles(), s, cal).score for s in families}
            right += min(scores, key=scores.get) == r.shape
        print(f"oracle, {name}: {100 * right / len(test):.1f}% of {len(test)} test grasps")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--oracle", action="store_true")
    args = ap.parse_args()
    provenance()
    records = [r for r in records_from(args.data)
               if "no_contact" not in r.flags and r.shape in _TABLE]  # fmt: skip
    if not records:
        sys.exit(f"{args.data} holds no grasp of a fitted shape")
    geometry, measured = features(records)
    shapes = np.array([r.shape for r in records])
    cal = oracle(geometry, measured)
    res = np.degrees(measured - cal.apply(geometry))
    touched = geometry[:, 2, :] >= 0
    print(f"{args.data}: {len(records)} grasps; fingers {', '.join(LONG_FINGERS)}")
    for j, name in enumerate(("J3", "J0")):
        spread = [res[touched[:, f], j, f].std() for f in range(4)]
        print(f"{name} residual spread per finger (deg): {np.round(spread, 1).tolist()}")
    print("mean residual per family (deg), J3 | J0 per finger:")
    for s in sorted(set(shapes)):
        m = shapes == s
        print(f"  {s:<12} {np.round(res[m, 0].mean(0), 1).tolist()} | "
              f"{np.round(res[m, 1].mean(0), 1).tolist()}")  # fmt: skip
    side, j0 = geometry[:, 2, :][touched], res[:, 1, :][touched]
    print("J0 residual by sideways fraction of the contact (deg): fraction, fingers, mean, sd")
    for v in np.unique(np.round(side, 2)):
        m = np.round(side, 2) == v
        print(f"  {v:4.2f} {m.sum():4d} {j0[m].mean():6.1f} {j0[m].std():5.1f}")
    xs = np.array([FINGER_X[f] for f in LONG_FINGERS])
    slope = np.zeros(geometry.shape[0:1] + (4,))
    for i, r in enumerate(records):
        x = xs - r.pose.offset[0]
        radius = _TABLE[r.shape].radius
        slope[i] = np.abs(radius(x + 1e-4, **r.params) - radius(x - 1e-4, **r.params)) / 2e-4
    slope = slope[touched]
    print("J0 residual by the profile's slope under the finger: |dr/dx|, fingers, mean, sd")
    for lo, hi in zip(SLOPES[:-1], SLOPES[1:], strict=True):
        m = (slope >= lo) & (slope < hi)
        if m.any():
            print(f"  {lo:g}-{hi:g} {m.sum():4d} {j0[m].mean():6.1f} {j0[m].std():5.1f}")
    if args.oracle:
        oracle_accuracies(records)


if __name__ == "__main__":
    main()
