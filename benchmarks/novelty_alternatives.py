"""Other ways to decide ``unknown``, tried on the first out-of-family set only (docs/robustness.md,
root causes): the distance to the training grasps in several feature spaces, with 1 or 5
neighbours, and the shape fit's residual. Each is calibrated as the shipped rule is (at most 5%
of held-out in-family training grasps unknown, on both engines' randomised hands) and scored on
every in-family column and on the first out-of-family set; the validation set is never read.

Usage: python benchmarks/novelty_alternatives.py --cache OUT/data [--scale full]
       [--other-hand menagerie=M.xml,gymnasium=G.xml]   (OUT: a robustness matrix's --out)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments import robustness as R
from tactile_bullet.experiments.benchmark import load_set
from tactile_bullet.learn import novelty as N
from tactile_bullet.plugins import get_descriptor

SPACES = ("coupled-finger-points", "finger-points", "raw-joints", "coupled-joints",
          "signature+coupled-joints", "robust-joints")  # fmt: skip
RESIDUAL_SAMPLE = 60
"""Grasps per column the shape fit's residual is scored on (a fit takes ~20-60 ms)."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", required=True)
    ap.add_argument("--scale", default="full")
    ap.add_argument("--other-hand", action="append")
    args = ap.parse_args()
    provenance()
    hands = R.parse_hands(args.other_hand)
    specs = R.set_specs(args.scale, hands, Path(args.cache) / "objects", R.plugin_shapes())
    names = [k for k in specs if k != R.OUT_OF_FAMILY_VALIDATION and "posed" not in k]
    sets = {k: load_set(Path(args.cache) / specs[k].name)[0] for k in names}
    train = [r for s in R.TRAININGS["both-randomized"] for r in sets[s]]
    cols = {c.name: R.read_column(c, sets, 0) for c in R.COLUMNS
            if all(s in sets for s in c.sets)}  # fmt: skip
    oof = sets[R.OUT_OF_FAMILY]
    y = R._labels(train)
    for space in SPACES:
        d = get_descriptor(space)
        x = np.asarray(d.transform(train), float)
        for k in (1, 5):
            fitted = N.Novelty.fit(x, y)
            if k != fitted.k:  # the same scale and reference, k neighbours, its own threshold
                ref = (x - fitted.centre) / fitted.scale
                held = np.array([N._knn_distance(ref[i:i + 1], np.delete(ref, i, 0), k)[0]
                                 for i in range(len(ref))])  # fmt: skip
                fitted = N.Novelty(fitted.centre, fitted.scale, fitted.reference,
                                   float(np.quantile(held, 1 - N.UNKNOWN_RATE)), k)  # fmt: skip
            inside = {c: float(np.mean(fitted.unknown(np.asarray(d.transform(r), float))))
                      for c, r in cols.items()}  # fmt: skip
            out = float(np.mean(fitted.unknown(np.asarray(d.transform(oof), float))))
            print(f"{space:26s} k={k}: out of family {100 * out:.1f}%, in family at most "
                  f"{100 * max(inside.values()):.1f}% ({max(inside, key=inside.get)})")  # fmt: skip
    _residual(train, cols, oof)


def _residual(train, cols, oof) -> None:
    """The shape fit's RMS residual as the score (threshold: its 95th percentile on a sample of
    the randomised training grasps)."""
    from tactile_bullet.learn.robust import angles_for_shape_fit
    from tactile_bullet.perception.shape_fit import fit_shape

    rng = np.random.default_rng(0)

    def residuals(records):
        pick = rng.choice(len(records), min(RESIDUAL_SAMPLE, len(records)), replace=False)
        return np.array([fit_shape(angles_for_shape_fit(records[i])).residual for i in pick])

    limit = float(np.quantile(residuals(train), 1 - N.UNKNOWN_RATE))
    inside = {c: float(np.mean(residuals(r) > limit)) for c, r in cols.items()}
    out = float(np.mean(residuals(oof) > limit))
    print(f"{'shape-fit residual':26s}    : out of family {100 * out:.1f}%, in family at most "
          f"{100 * max(inside.values()):.1f}% ({max(inside, key=inside.get)})")


if __name__ == "__main__":
    main()
