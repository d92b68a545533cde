"""A rule tried and not built: where a grasp's contacts reject the family the model names but
accept its runner-up, answer ``ambiguous`` (named, runner-up) instead of ``unknown``.

Most in-family grasps answered ``unknown`` by the contact rules are wrong answers whose
contacts reject the family named (a hyperboloid read as a cylinder misses a cylinder's tight
axis threshold): the object *is* explained by a family, the runner-up. This scores the rule on
a robustness matrix's cached grasps, for the shipped default: per out-of-family set and
in-family column (those with contacts), the grasps answered unknown as shipped and under the
rule, and the rescued ones (how many were wrong answers, and how many would be right if
renamed to the runner-up). Variants by ``--require``: ``profile`` (the runner-up must also be
judged by the profile rule: no torus), ``p05`` (its probability at least 0.05).

    python benchmarks/unknown_rescue.py --cache OUT/data --replicate 10 [--require profile,p05]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _report import matrix_column, matrix_set, provenance  # first: this checkout ahead

from tactile_bullet.experiments.robustness_sets import (
    COLUMNS,
    FAMILY_OBJECTS,
    OUT_OF_FAMILY_SETS,
)
from tactile_bullet.learn.default import resolve_model
from tactile_bullet.learn.doubt import UNLIKE_TRAINING, doubts

CONTACT_COLUMNS = ("sizes", "poses", "turned", "shift", "equal-split", "mujoco", "household")
"""In-family columns whose grasps carry the simulator's contacts (the others are read through
a sensor model or a hand's CSV, where the contact rules say nothing)."""


def judge(model, records, truths, require: set[str]) -> dict:
    classes = [str(c) for c in model.classes]
    names, proba, _ = model.answers(records)
    names = [str(n) for n in names]
    found = doubts(model, records, names, proba, cross_check=False)
    asked = [i for i, d in enumerate(found)
             if d["unknown"] and d["unknown_why"] != UNLIKE_TRAINING]  # fmt: skip
    runner = [next(classes[j] for j in np.argsort(-proba[i]) if classes[j] != names[i])
              for i in asked]  # fmt: skip
    verdicts = model.axis.verdicts([records[i] for i in asked], runner) if asked else []
    rescued = {}
    for i, r, v in zip(asked, runner, verdicts, strict=True):
        if v.unknown_why is not None or v.axis_residual is None:
            continue
        if "profile" in require and v.profile_residual is None:
            continue
        if "p05" in require and proba[i][classes.index(r)] < 0.05:
            continue
        rescued[i] = r
    unknown = sum(bool(d["unknown"]) for d in found)
    out = f"{len(records)} grasps, unknown {unknown} -> {unknown - len(rescued)}"
    if truths is not None:
        wrong = sum(truths[i] != names[i] for i in rescued)
        renamed = sum(truths[i] == r for i, r in rescued.items())
        out += f" (rescued: {wrong} wrong answers, {renamed} right if renamed)"
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", required=True, help="a robustness matrix's data folder")
    ap.add_argument("--replicate", type=int, default=0, help="the run's --replicate")
    ap.add_argument("--require", default="", help="profile, p05 (comma-separated)")
    args = ap.parse_args(argv)
    provenance(argv)
    require = {r for r in args.require.split(",") if r}
    model = resolve_model(None)
    cache = Path(args.cache)
    for name in OUT_OF_FAMILY_SETS:
        records = matrix_set(cache, name, args.replicate)
        print(f"{name}: {judge(model, records, None, require)}", flush=True)
    table = {c.name: c for c in COLUMNS}
    for name in CONTACT_COLUMNS:
        column = table[name]
        records = matrix_column(cache, column, args.replicate)
        truths = [FAMILY_OBJECTS.get(r.shape, r.shape) for r in records]
        print(f"{name}: {judge(model, records, truths, require)}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
