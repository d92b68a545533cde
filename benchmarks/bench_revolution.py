"""The contact rules' latency behind ``unknown``: the axis residual (``perception/revolution.py``)
per grasp batched, one grasp at a time (what `grasp` and `identify` pay), and scipy's
``least_squares`` on the same soft-L1 problem from the same starts (the solver it was designed
with), with the largest difference between the two residuals; then the profile residual
(``perception/profile_fit.py``) batched and one at a time, on each grasp's own family.

Inputs: 15 touching links per grasp on cylinders, cones and spheres turned 0-25 deg, with
2 deg of noise on every normal (seeded): no dataset, no simulation. Ratios hold on a noisy
machine where milliseconds do not.

With ``--data DIR`` (repeatable: a simulated dataset, such as a robustness matrix's cached
sets), the same comparison on its grasps: how many reach another optimum than scipy's, and how
far apart.

Usage: python benchmarks/bench_revolution.py [--grasps N] [--data DIR ...]
"""

from __future__ import annotations

import argparse
import math
import time
from types import SimpleNamespace

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.perception import revolution


def grasps(n: int, seed: int = 0) -> list:
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        beta = math.radians(rng.uniform(0, 25))
        c, s = math.cos(beta), math.sin(beta)
        turn = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
        radius, slope = rng.uniform(0.025, 0.05), (0.0, -0.15, None)[i % 3]
        points, normals = [], []
        for x in np.linspace(-0.035, 0.035, 5):
            for k in range(3):
                phi = math.radians(200 + 60 * k + rng.uniform(-10, 10))
                radial = np.array([0.0, math.cos(phi), math.sin(phi)])
                if slope is None:  # a sphere: the normal points away from its centre
                    p = np.array([x, 0, 0]) + math.sqrt(radius**2 + 0.04**2 - x**2) * radial
                    n = p / np.linalg.norm(p)
                else:
                    p = np.array([x, 0, 0]) + (radius + slope * x) * radial
                    n = radial - slope * np.array([1.0, 0, 0])
                n = n / np.linalg.norm(n) + rng.normal(0, math.radians(2.0), 3)
                points.append(turn @ p + (0.0, -0.06, 0.12))
                normals.append(turn @ (n / np.linalg.norm(n)))
        out.append(SimpleNamespace(contact_link=np.array([f"l{j}" for j in range(15)]),
                                   contact_position=np.array(points),
                                   contact_normal=np.array(normals)))  # fmt: skip
    return out


def scipy_residual(record) -> float:
    from scipy.optimize import least_squares

    points, normals = revolution.link_contacts(record)

    def products(theta):
        e, _ = revolution._terms(np.asarray(theta)[None], points[None], normals[None])
        return e[0]

    best = None
    for tilt in revolution.START_TILTS:
        start = [0.0, tilt, points[:, 1].mean() - 0.03, points[:, 2].mean()]
        sol = least_squares(products, start, loss="soft_l1", f_scale=revolution.LOSS_KNEE)
        best = sol if best is None or sol.cost < best.cost else best
    return float(np.sqrt(np.mean(products(best.x) ** 2)))


def compare(folder: str) -> None:
    from tactile_bullet.datasets.dataset import read_records

    records = read_records(folder).records
    start = time.perf_counter()
    batched = revolution.axis_residuals(records)
    took = (time.perf_counter() - start) / len(records)
    pairs = [(a, scipy_residual(r)) for a, r in zip(batched, records, strict=True)
             if a is not None]  # fmt: skip
    apart = [abs(a - b) for a, b in pairs if abs(a - b) > 5e-5]
    lower = sum(a < b - 5e-5 for a, b in pairs)
    print(f"{folder}: {len(records)} grasps, {len(pairs)} with a residual, "
          f"{1e3 * took:.2f} ms a grasp batched; another optimum than scipy's on {len(apart)} "
          f"(lower on {lower}; largest {1e3 * max(apart, default=0.0):.2g} mm apart)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--grasps", type=int, default=200)
    ap.add_argument("--data", action="append", default=[], help="a simulated dataset")
    args = ap.parse_args(argv)
    provenance(argv)
    for folder in args.data:
        compare(folder)
    records = grasps(args.grasps)
    revolution.axis_residuals(records[:2])  # imports before timing
    start = time.perf_counter()
    batched = revolution.axis_residuals(records)
    t_batch = (time.perf_counter() - start) / len(records)
    start = time.perf_counter()
    single = [revolution.axis_residual(r) for r in records]
    t_single = (time.perf_counter() - start) / len(records)
    start = time.perf_counter()
    reference = [scipy_residual(r) for r in records]
    t_scipy = (time.perf_counter() - start) / len(records)
    diff = max(abs(a - b) for a, b in zip(batched, reference, strict=True))
    same = max(abs(a - b) for a, b in zip(batched, single, strict=True))
    print(f"{len(records)} grasps: batched {1e3 * t_batch:.3f} ms a grasp, one at a time "
          f"{1e3 * t_single:.2f} ms, scipy least_squares {1e3 * t_scipy:.2f} ms "
          f"({t_scipy / t_single:.1f}x one at a time, {t_scipy / t_batch:.0f}x batched)")
    print(f"residuals: batched against one at a time within {1e3 * same:.2g} mm, against "
          f"scipy within {1e3 * diff:.2g} mm (median residual "
          f"{1e3 * float(np.median(batched)):.2f} mm)")  # fmt: skip
    from tactile_bullet.perception.profile_fit import profile_residuals

    families = [("cylinder", "cone", "sphere")[i % 3] for i in range(len(records))]
    start = time.perf_counter()
    profiles = profile_residuals(records, families)
    p_batch = (time.perf_counter() - start) / len(records)
    start = time.perf_counter()
    for r, f in zip(records[:20], families[:20], strict=True):
        profile_residuals([r], [f])
    p_single = (time.perf_counter() - start) / 20
    print(f"profile residual: batched {1e3 * p_batch:.2f} ms a grasp, one at a time "
          f"{1e3 * p_single:.1f} ms (median {1e3 * float(np.median(profiles)):.3f} mm on each "
          "grasp's own family)")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
