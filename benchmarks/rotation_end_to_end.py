"""Rotation about the palm normal end to end, the shape unknown (issue 21 item 6).

Simulates the torus, hyperboloid and cylinder at their default sizes (or at the relative sizes
given with --sizes), turned 0 to 25 deg in 5 deg steps, and prints the mean absolute error of
each way to read the rotation from the grasp alone:

- ``end to end``: ``perception.summary.rotation_from_grasp`` (the signature's alpha with the
  line of the calibrated family the shape fit finds best; ``grasp --json``'s ``rotation_deg``);
- ``true shape's line``: the same alpha with the grasped shape's own line (the shape known);
- ``DTW nearest's line``: ``grasp --json``'s ``rotation_estimate_deg`` (None where the nearest
  pattern has no line: counted apart);
- ``shape fit's rotation``: the rotation the shape fit itself searches (best family).

The calibration (``data/rotation_calibration.json``, ``tools/rotation_calibration.py``) is fitted
on sizes at 0, 25 and 50% of each range, never on the default sizes measured here.

Usage: python benchmarks/rotation_end_to_end.py [--workers 2] [--sizes default,0.25]  (~30 s a size)
"""

from __future__ import annotations

import argparse
import time
from multiprocessing import Pool

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

SHAPES = ("torus", "hyperboloid", "cylinder")
ROTATIONS_DEG = tuple(range(0, 30, 5))


def grasp_job(job: tuple):
    from tactile_bullet.objects.shapes import BUILTIN_SHAPES
    from tactile_bullet.records import Pose
    from tactile_bullet.sim.grasp import simulate_grasp

    name, size, deg = job
    spec = next(s for s in BUILTIN_SHAPES if s.name == name)
    if size == "default":
        params = spec.resolve()
    else:
        t = float(size)
        params = spec.resolve({k: p.min + t * (p.max - p.min) for k, p in spec.params.items()})
    try:
        return simulate_grasp(spec, params, Pose(rotation=np.radians(deg)))
    except ValueError as exc:
        return f"{name} {size} {deg} deg refused: {exc}"


def readings(record) -> dict[str, float | None]:
    from tactile_bullet.perception import shape_fit
    from tactile_bullet.perception.rotation import alpha_of, load_calibration
    from tactile_bullet.perception.signature import signature_of
    from tactile_bullet.perception.summary import rotation_from_grasp, signature_summary

    cal = load_calibration()
    alpha = alpha_of(signature_of(record), cal.line)
    summary = signature_summary(record)
    return {
        "end to end": rotation_from_grasp(record)[0],
        "true shape's line": cal.estimate(alpha, record.shape),
        "DTW nearest's line": summary["rotation_estimate_deg"],
        "shape fit's rotation": shape_fit.fit_shape(record.fci_angles()).best.rotation_deg,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--sizes", default="default", help="'default' and/or relative sizes")
    args = ap.parse_args()
    provenance()
    sizes = [s.strip() for s in args.sizes.split(",") if s.strip()]
    jobs = [(n, s, d) for s in sizes for n in SHAPES for d in ROTATIONS_DEG]
    start = time.perf_counter()
    with Pool(args.workers) as pool:
        out = pool.map(grasp_job, jobs)
    print(f"simulated {len(jobs)} grasps in {time.perf_counter() - start:.0f} s")
    for size in sizes:
        errors: dict[str, list[float]] = {}
        missing: dict[str, int] = {}
        per_shape: dict[str, list[float]] = {n: [] for n in SHAPES}
        for (name, s, deg), rec in zip(jobs, out, strict=True):
            if s != size:
                continue
            if isinstance(rec, str):
                print("  " + rec)
                continue
            for way, value in readings(rec).items():
                if value is None:
                    missing[way] = missing.get(way, 0) + 1
                    continue
                errors.setdefault(way, []).append(abs(value - deg))
                if way == "end to end":
                    per_shape[name].append(abs(value - deg))
        print(f"sizes: {size}")
        for way, errs in errors.items():
            none = f", no answer for {missing[way]}" if missing.get(way) else ""
            print(f"  {way:<22} MAE {np.mean(errs):5.2f} deg  max {np.max(errs):5.2f} deg "
                  f"over {len(errs)} grasps{none}")  # fmt: skip
        print("  end to end by shape: " + ", ".join(
            f"{n} {np.mean(v):.2f}" for n, v in per_shape.items() if v))  # fmt: skip


if __name__ == "__main__":
    main()
