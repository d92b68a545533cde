"""Shape fits per second against worker processes: ``perception/fit_batch.fit_many`` on the same
grasps with 1 worker (in this process) and with each count up to the usable cores, each timed
from an empty fit cache (the grids built before any timing). The figure is the ratio to 1
worker, which holds on a noisy machine where fits per second do not.

Inputs: the model's own angles for random sizes and poses of the five thesis shapes, 1 deg of
noise (seeded), the same for every worker count.

Usage: python benchmarks/bench_fit_batch.py [--grasps N] [--workers 1,2] [--repeat K]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.errors import UsageError
from tactile_bullet.objects.shapes import BUILTIN_SHAPES, THESIS_SHAPES
from tactile_bullet.perception import fit_batch, fit_cache, shape_fit


def model_grasps(n: int, seed: int = 0) -> list[np.ndarray]:
    """(3, 4) angles of ``n`` random thesis-shape grasps, as the forward model predicts them,
    with 1 deg of noise; J0 split evenly between J2 and J1."""
    rng = np.random.default_rng(seed)
    table = {s.name: s for s in BUILTIN_SHAPES}
    out: list[np.ndarray] = []
    while len(out) < n:
        spec = table[THESIS_SHAPES[len(out) % len(THESIS_SHAPES)]]
        sizes = {k: rng.uniform(p.min, p.max) for k, p in spec.params.items()}
        try:
            j3, j0 = shape_fit.predicted_angles(
                spec.name, sizes, tuple(rng.uniform(-0.01, 0.01, 2)),
                rotation_deg=rng.uniform(-20.0, 20.0),
            ) + rng.normal(0.0, np.radians(1.0), (2, 4))  # fmt: skip
        except UsageError:  # sizes that make no such solid
            continue
        out.append(np.stack([j3, j0 / 2.0, j0 / 2.0]))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--grasps", type=int, default=96)
    ap.add_argument("--workers", default=None, help="counts to time (default 1 to the cores)")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args(argv)
    provenance(argv)
    counts = ([int(w) for w in args.workers.split(",")] if args.workers
              else list(range(1, fit_batch.usable_cores() + 1)))  # fmt: skip
    grasps = model_grasps(args.grasps)
    shape_fit.fit_shape(grasps[0], THESIS_SHAPES)  # the grids, built or read, before timing
    best: dict[int, float] = {}
    for _ in range(args.repeat):
        for w in counts:  # alternated, so a load change hits every count alike
            fit_cache._FITS.clear()
            start = time.perf_counter()
            fit_batch.fit_many(grasps, THESIS_SHAPES, workers=w)
            best[w] = min(best.get(w, np.inf), time.perf_counter() - start)
    print(f"{len(grasps)} fits of the five thesis shapes, {fit_batch.usable_cores()} usable "
          f"cores; best of {args.repeat}")  # fmt: skip
    for w in counts:
        print(f"  {w} worker(s): {best[w]:.2f} s, {len(grasps) / best[w]:.1f} fits/s, "
              f"{best[counts[0]] / best[w]:.2f}x {counts[0]} worker(s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
