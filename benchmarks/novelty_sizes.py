"""A change to the novelty rule against the rule before it ("per grasp": held-out folds of
whole grasps, no midpoints, as shipped until the fifteenth replicate), on a robustness
matrix's cached grasps: ``--variant sizes-held-out``, the threshold calibrated with whole
sizes held out (``novelty.HOLD_OUT_SIZES``, judged on the fourteenth replicate), or
``--variant midpoints``, the reference holding midpoints of training grasps of neighbouring
sizes (``novelty.SIZE_MIDPOINTS``, judged on the fifteenth and kept).

Both novelties are fitted on the shipped default's training (read from the cache, as the
matrix fits it) with the default's own features; every other part of the model is the shipped
one, so only the novelty rule's verdicts differ. For each in-family column and each
out-of-family set: grasps answered unknown both ways, and the wrong answers among them; then
the grasps the per-grasp calibration calls unlike the training (novelty), by shape, engine and
size, each with how far the nearest training grasp of that shape and engine lies in size (mm:
the largest difference of one size parameter); then
the rule declared before the fourteenth replicate (docs/robustness.md): (a) in-family grasps
answered unknown, summed over the columns, fall; (b) out-of-family grasps answered unknown fall
by at most 2 on each set; (c) wrong answers answered unknown, summed over the in-family
columns, fall by at most 2; and, declared before the fifteenth for ``midpoints``, (d) the
out-of-family grasps the novelty rule alone calls unlike the training (its verdict whatever
the contacts say: all a hand without contact sensing has) fall by at most 2 on each set.

    python benchmarks/novelty_sizes.py --cache OUT/data --replicate 14
    python benchmarks/novelty_sizes.py --cache OUT/data --replicate 15 --variant midpoints
"""

from __future__ import annotations

import argparse
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np
from _report import matrix_column, matrix_set, provenance  # first: this checkout ahead
from unknown_by_rule import _answers

from tactile_bullet.experiments import robustness as R
from tactile_bullet.experiments.robustness_sets import COLUMNS, OUT_OF_FAMILY_SETS
from tactile_bullet.learn import novelty as N
from tactile_bullet.learn.default import default_meta, default_model

VARIANTS = ("sizes-held-out", "midpoints")


def thresholds(model, train, variant: str = "sizes-held-out") -> dict[str, N.Novelty]:
    """The novelty fitted on ``train`` per grasp, without midpoints, and as ``variant`` has
    it."""
    x = model.features(train)
    y = np.array([R.FAMILY_OBJECTS.get(r.shape, r.shape) for r in train])
    out = {"per grasp": N.Novelty.fit(x, y, groups=N.calibration_groups(train),
                                      pairs=N.midpoint_pairs(train, on=False))}  # fmt: skip
    if variant == "midpoints":
        out[variant] = N.Novelty.fit(x, y, groups=N.calibration_groups(train),
                                     pairs=N.midpoint_pairs(train, on=True))  # fmt: skip
        return out
    N.HOLD_OUT_SIZES = True
    try:
        out[variant] = N.Novelty.fit(x, y, groups=N.calibration_groups(train))
    finally:
        N.HOLD_OUT_SIZES = False
    return out


def size_gaps(flagged, train) -> list[str]:
    """One line per distinct (shape, engine, sizes) of ``flagged``: how many grasps, and the
    nearest training size of that shape on that engine (mm apart, largest parameter)."""
    sizes: dict[tuple, list[np.ndarray]] = {}
    for r in train:
        key = (r.shape, r.controller.engine)
        sizes.setdefault(key, []).append(np.array([r.params[k] for k in sorted(r.params)]))
    groups: Counter = Counter()
    for r in flagged:
        groups[(r.shape, r.controller.engine, tuple(sorted(r.params.items())))] += 1
    lines = []
    for (shape, engine, params), n in sorted(groups.items()):
        here = np.array([v for _, v in params])
        known = np.array(sizes.get((shape, engine), [])).reshape(-1, len(here))
        gap = 1000 * np.abs(known - here).max(axis=1).min() if len(known) else float("nan")
        shown = ", ".join(f"{k} {1000 * v:.1f} mm" for k, v in params)
        lines.append(f"  {n} x {shape} ({shown}) on {engine}: nearest training size {gap:.1f} "
                     "mm away")  # fmt: skip
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", required=True, help="a robustness matrix's data folder")
    ap.add_argument("--replicate", type=int, default=0, help="the run's --replicate")
    ap.add_argument("--seed", type=int, default=0, help="the run's --seed")
    ap.add_argument("--variant", choices=VARIANTS, default=VARIANTS[0])
    args = ap.parse_args(argv)
    provenance(argv)
    cache = Path(args.cache)
    model = default_model()
    train = R.training_records(cache, "full", default_meta()["training"])
    fitted = thresholds(model, train, args.variant)
    new = args.variant
    print(", ".join(f"{k}: threshold {v.threshold:.3f}, reference {len(v.reference)}"
                    for k, v in fitted.items()))  # fmt: skip
    variants = {k: replace(model, novelty=v) for k, v in fitted.items()}
    totals = {k: [0, 0] for k in variants}  # in-family unknown, wrong answers unknown
    lost, lost_alone = {}, {}
    for name in OUT_OF_FAMILY_SETS:
        records = matrix_set(cache, name, args.replicate)
        found = {k: sum(r is not None for r in _answers(m, records)[1]) for k, m in
                 variants.items()}  # fmt: skip
        features = model.features(records)
        alone = {k: int(v.unknown(features).sum()) for k, v in fitted.items()}
        lost[name] = found["per grasp"] - found[new]
        lost_alone[name] = alone["per grasp"] - alone[new]
        print(f"{name:26s} {len(records):4d} grasps, unknown: "
              + ", ".join(f"{k} {v}" for k, v in found.items())
              + "; by the novelty rule alone: " + ", ".join(f"{k} {v}" for k, v in alone.items()))
    for column in COLUMNS:
        records = matrix_column(cache, column, args.replicate, args.seed)
        truths = np.array([R.FAMILY_OBJECTS.get(r.shape, r.shape) for r in records])
        cells = []
        for key, m in variants.items():
            names, rules, _ = _answers(m, records)
            unknown = np.array([r is not None for r in rules])
            wrong = np.asarray(names).astype(str) != truths
            totals[key][0] += int(unknown.sum())
            totals[key][1] += int((unknown & wrong).sum())
            cells.append(f"{key} {int(unknown.sum())} ({int((unknown & wrong).sum())} wrong)")
            if key == "per grasp":
                novel = [r for r, why in zip(records, rules, strict=True) if why == "novelty"]
        print(f"{column.name:26s} {len(records):4d} grasps, unknown: " + ", ".join(cells))
        if novel and all(r.params for r in novel):
            print("\n".join(size_gaps(novel, train)))
    (old_u, old_w), (new_u, new_w) = totals["per grasp"], totals[new]
    checks = [
        (new_u < old_u, f"(a) in-family grasps answered unknown, summed: {old_u} -> {new_u} "
                        "(must fall)"),
        (all(v <= 2 for v in lost.values()), "(b) out-of-family grasps no longer unknown: "
         + ", ".join(f"{k} {v}" for k, v in lost.items()) + " (at most 2 each)"),
        (old_w - new_w <= 2, f"(c) wrong answers answered unknown, summed: {old_w} -> {new_w} "
                             "(fall by at most 2)"),
    ]  # fmt: skip
    if new == "midpoints":
        checks.append((all(v <= 2 for v in lost_alone.values()),
                       "(d) out-of-family grasps the novelty rule alone no longer flags: "
                       + ", ".join(f"{k} {v}" for k, v in lost_alone.items())
                       + " (at most 2 each)"))  # fmt: skip
    print("\n".join(text for _, text in checks))
    print("declared rule:", "kept" if all(ok for ok, _ in checks) else "reverted")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
