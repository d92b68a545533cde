"""The cross-check's tolerance (``learn/doubt.CROSS_CHECK_TOLERANCE``) against none, on a
robustness matrix's cached grasps: how the shipped default's doubt flags wrong and right
answers on every in-family column either way.

An answer is flagged where it is ``ambiguous`` or ``unknown`` (as the matrix counts it). Both
ways read the same shape fits (each grasp fitted once); only which of the fit's families count
as its answer differs. Prints, per column, wrong and right answers flagged each way, then the
rule declared before the sixteenth replicate (docs/robustness.md): (a) right answers flagged,
summed over the in-family columns, fall by at least 10; (b) wrong answers flagged, summed, fall
by at most 3; (c) no fewer columns flag at least 80% of their wrong answers at most 5% of their
right ones.

    python benchmarks/cross_check_tolerance.py --cache OUT/data --replicate 16 --tolerance 1.0
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
from _report import (  # first: this checkout ahead of an installed copy
    doubt_cell,
    matrix_column,
    provenance,
)

from tactile_bullet.experiments import robustness as R
from tactile_bullet.experiments.robustness_sets import COLUMNS
from tactile_bullet.learn import doubt as D
from tactile_bullet.learn.default import default_model


def flags(model, records, answers, tolerance: float) -> np.ndarray:
    """Which of the model's ``answers`` on ``records`` (``Model.answers``' three lists) are
    flagged with the cross-check's tolerance at ``tolerance``."""
    names, proba, was = answers
    kept = D.CROSS_CHECK_TOLERANCE
    D.CROSS_CHECK_TOLERANCE = tolerance
    try:
        found = D.doubts(model, records, names, proba, renamed_from=was)
    finally:
        D.CROSS_CHECK_TOLERANCE = kept
    return D.flagged_answers(found)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", required=True, help="a robustness matrix's data folder")
    ap.add_argument("--replicate", type=int, default=0, help="the run's --replicate")
    ap.add_argument("--seed", type=int, default=0, help="the run's --seed")
    ap.add_argument("--tolerance", type=float, default=1.0)
    args = ap.parse_args(argv)
    provenance(argv)
    cache = Path(args.cache)
    # the shape fit's cross-check, as the default had it before it carried a second svm
    model = dataclasses.replace(default_model(), second=None)
    ways = {"none": 0.0, f"tolerance {args.tolerance:g}": args.tolerance}
    totals = {k: [0, 0] for k in ways}  # wrong flagged, right flagged
    met = {k: 0 for k in ways}
    for column in COLUMNS:
        records = matrix_column(cache, column, args.replicate, args.seed)
        names, proba, was = model.answers(records)
        names = [str(n) for n in names]
        truth = np.array([R.FAMILY_OBJECTS.get(r.shape, r.shape) for r in records])
        right = np.asarray(names) == truth
        cells = []
        for key, tol in ways.items():  # the answers once; only the doubt differs
            w, r, ok, cell = doubt_cell(key, flags(model, records, (names, proba, was), tol), right)
            totals[key][0] += w
            totals[key][1] += r
            met[key] += ok
            cells.append(cell)
        print(f"{column.name:12s} " + "; ".join(cells), flush=True)
    (old_w, old_r), (new_w, new_r) = totals.values()
    old_m, new_m = met.values()
    checks = [
        (old_r - new_r >= 10, f"(a) right answers flagged, summed: {old_r} -> {new_r} "
                              "(fall by at least 10)"),
        (old_w - new_w <= 3, f"(b) wrong answers flagged, summed: {old_w} -> {new_w} "
                             "(fall by at most 3)"),
        (new_m >= old_m, f"(c) columns meeting the target: {old_m} -> {new_m} (no fewer)"),
    ]  # fmt: skip
    print("\n".join(text for _, text in checks))
    print("declared rule:", "kept" if all(ok for ok, _ in checks) else "reverted")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
