"""A learned second opinion against the shape fit's: how the shipped default's doubt flags wrong
and right answers on every in-family column of a robustness matrix's cached grasps, either way.

The shipped way: an answer is flagged where it is ``ambiguous`` or ``unknown`` as the matrix
counts it, the shape fit seconding each answer (``learn/doubt.CROSS_CHECK``). The other way
(declared before the seventeenth replicate, docs/robustness.md): the shape fit seconds nothing;
instead an svm trained on the default's own training grasps, reading ``robust-coupled-joints``
(the zeroed, plateau-averaged J4, J3 and J0 of each long finger), seconds every answer, and an
answer it names otherwise is flagged. The unknown rules and the margin are the same both ways.

Prints, per column, wrong and right answers flagged each way, then the declared checks: (a) more
in-family columns flag at least 80% of their wrong answers at most 5% of their right ones;
(b) right answers flagged, summed over the in-family columns, fall by at least 20; (c) wrong
answers flagged, summed, fall by at most 2.

    python benchmarks/second_opinion.py --cache OUT/data --replicate 17
"""

from __future__ import annotations

import argparse
import dataclasses
import time
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
from tactile_bullet.learn.default import default_meta, default_model
from tactile_bullet.learn.second_opinion import SecondOpinion


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", required=True, help="a robustness matrix's data folder")
    ap.add_argument("--replicate", type=int, default=0, help="the run's --replicate")
    ap.add_argument("--seed", type=int, default=0, help="the run's --seed")
    args = ap.parse_args(argv)
    provenance(argv)
    cache = Path(args.cache)
    shipped_model = default_model()
    # the shape fit's way: the default as it was, with no second classifier
    model = dataclasses.replace(shipped_model, second=None)
    start = time.perf_counter()
    if shipped_model.second is not None:  # kept on replicate 17: the shipped one, as answers
        second = shipped_model.second
        print("second opinion: the shipped default's own "
              f"({second.descriptor} + {second.classifier})", flush=True)
    else:
        train = R.training_records(cache, "full", default_meta()["training"])
        second = SecondOpinion.fit(train, [str(r.shape) for r in train])
        print(f"second opinion: {second.descriptor} + {second.classifier} on the default's "
              f"{len(train)} training rows ({time.perf_counter() - start:.0f} s)", flush=True)
    ways = ("shape fit", "second svm")
    totals = {k: [0, 0] for k in ways}  # wrong flagged, right flagged
    met = {k: 0 for k in ways}
    for column in COLUMNS:
        records = matrix_column(cache, column, args.replicate, args.seed)
        names, proba, was = model.answers(records)
        names = np.array([str(n) for n in names])
        truth = np.array([R.FAMILY_OBJECTS.get(r.shape, r.shape) for r in records])
        right = names == truth
        shipped = D.flagged_answers(D.doubts(model, records, names, proba, renamed_from=was))
        bare = D.flagged_answers(D.doubts(model, records, names, proba, cross_check=False,
                                renamed_from=was))  # fmt: skip
        others = np.array(second.names(records))
        cells = []
        for key, flags in zip(ways, (shipped, bare | (others != names)), strict=True):
            w, r, ok, cell = doubt_cell(key, flags, right)
            totals[key][0] += w
            totals[key][1] += r
            met[key] += ok
            cells.append(cell)
        print(f"{column.name:12s} " + "; ".join(cells), flush=True)
    (old_w, old_r), (new_w, new_r) = totals.values()
    old_m, new_m = met.values()
    checks = [
        (new_m > old_m, f"(a) columns meeting the target: {old_m} -> {new_m} (more)"),
        (old_r - new_r >= 20, f"(b) right answers flagged, summed: {old_r} -> {new_r} "
                              "(fall by at least 20)"),
        (old_w - new_w <= 2, f"(c) wrong answers flagged, summed: {old_w} -> {new_w} "
                             "(fall by at most 2)"),
    ]  # fmt: skip
    for ok, text in checks:
        print(f"{'met' if ok else 'FAILED'}: {text}")
    print("verdict: " + ("kept" if all(ok for ok, _ in checks) else "reverted"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
