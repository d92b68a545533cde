"""The doubt's cross-check against the whole shape fit: the same family, at what cost a grasp.

The cross-check reads only the family the shape fit names (``fit_batch.fit_names``): where
the grid decides it (every start near enough to be refined is of one family), the sizes are not
searched for. For each dataset given: how many grasps the grid decides, whether every name
equals the whole fit's (``fit_shape``), and the time a grasp of each, in this process (one
core), the grids built and the coefficients applied before timing. The families are the
dataset's own shapes where they are not the five thesis shapes (the ``modified`` preset's
ovoid and hexagonal pyramid), else the thesis shapes.

Usage: python benchmarks/bench_cross_check.py DATA [DATA ...]
"""

from __future__ import annotations

import sys
import time

from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.datasets.dataset import read_records
from tactile_bullet.learn.robust import angles_for_shape_fit
from tactile_bullet.objects.shapes import THESIS_SHAPES
from tactile_bullet.perception import fit_cache, shape_fit
from tactile_bullet.perception.fit_batch import fit_names


def _fresh() -> None:
    fit_cache._FITS.clear()
    fit_cache._NAMES.clear()


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__.strip().splitlines()[-1])
        return 2
    provenance()
    for data in argv:
        records = read_records(data).records
        shapes = sorted({str(r.shape) for r in records})
        families = list(THESIS_SHAPES) if set(shapes) <= set(THESIS_SHAPES) else shapes
        angles = [angles_for_shape_fit(r) for r in records]
        for a in angles[:3]:  # grids read, coefficients applied: not timed
            shape_fit.fit_shape(a, families)
        _fresh()
        start = time.perf_counter()
        names = fit_names(angles, families, workers=1)
        named = time.perf_counter() - start
        decided = len(fit_cache._NAMES)
        _fresh()
        start = time.perf_counter()
        whole = [shape_fit.fit_shape(a, families).shape for a in angles]
        fitted = time.perf_counter() - start
        same = sum(a == b for a, b in zip(names, whole, strict=True))
        n = len(angles)
        print(f"{data}: {n} grasps; decided on the grid {decided} ({100 * decided / n:.0f}%); "
              f"same family {same}/{n}; cross-check {1000 * named / n:.1f} ms a grasp, whole "
              f"fit {1000 * fitted / n:.1f} ms ({fitted / named:.2f}x)", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
