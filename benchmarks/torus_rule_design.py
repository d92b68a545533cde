"""The design figures of the ninth replicate's declaration (docs/robustness.md): on replicate
runs' cached grasps, what the contacts say of the sphere answers the profile rule rejects, and
what the two forms of the rule that were not adopted would have done.

For each replicate: (1) the torus residual of every sphere answer the profile rule rejects, in
family (the columns asked for) and out of family, whose gap is the adopted rule's margin;
(2) renaming such an answer to any family whose own checks pass, by the classifier's
probabilities: how many out-of-family grasps it would name a family; (3) a torus profile check
on answers named torus, its threshold the 99% of the training tori per engine: how many grasps
of each set it would answer unknown. The answers are the shipped default's classifier's,
before any renaming.

    python benchmarks/torus_rule_design.py --runs OUT4,OUT5,OUT6,OUT7,OUT8
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

import numpy as np
from _report import matrix_column, matrix_set, provenance  # first: this checkout ahead

from tactile_bullet.experiments import robustness as R
from tactile_bullet.experiments.robustness_sets import COLUMNS, OUT_OF_FAMILY_SETS
from tactile_bullet.learn.default import default_meta, resolve_model
from tactile_bullet.learn.doubt import NOT_PROFILE, doubts
from tactile_bullet.perception import contact_check
from tactile_bullet.perception.profile_fit import FAMILIES, profile_residuals, torus_residuals

FAMILY_NAMES = (*FAMILIES, "torus")


def _profiles(records) -> dict[str, np.ndarray]:
    """Every family's profile residual (the torus's from its own fit) of each record."""
    out = {f: profile_residuals(records, [f] * len(records)) for f in FAMILIES}
    out["torus"] = torus_residuals(records)
    return {f: np.array([np.nan if v is None else v for v in vals]) for f, vals in out.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", required=True, help="replicate runs' --out folders, comma-separated")
    ap.add_argument("--columns", default="sizes,poses,turned,shift,equal-split,mujoco,household",
                    help="in-family columns")  # fmt: skip
    args = ap.parse_args(argv)
    provenance(argv)
    contact_check.TORUS_FOR_SPHERE = False  # the classifier's own answers
    model = resolve_model(None)
    check = model.axis
    classes = [str(c) for c in model.classes]
    first = Path(args.runs.split(",")[0]) / "data"
    tori = [r for r in R.training_records(first, "full", default_meta()["training"],
                                          noisy=False) if r.shape == "torus"]  # fmt: skip
    fits = np.array([np.nan if v is None else v for v in torus_residuals(tori)])
    limit = {}
    for engine in sorted({contact_check._engine(r) for r in tori}):
        mine = np.array([contact_check._engine(r) == engine for r in tori]) & np.isfinite(fits)
        limit[engine] = float(np.quantile(fits[mine], 0.99, method="higher"))
    print("torus check's thresholds (99% of the training tori): "
          + ", ".join(f"{e} {1000 * v:.2f} mm" for e, v in limit.items()))  # fmt: skip
    table = {c.name: c for c in COLUMNS}
    for run in args.runs.split(","):
        config = json.loads((Path(run) / "robustness.json").read_text())["config"]
        doc_rep = int(config.get("replicate", 0))
        cache = Path(run) / "data"
        sets = [(n, matrix_set(cache, n, doc_rep), False)
                for n in OUT_OF_FAMILY_SETS]  # fmt: skip
        for name in args.columns.split(","):
            column = table[name]
            sets.append((name, matrix_column(cache, column, doc_rep), True))
        margins: dict[bool, list[float]] = {True: [], False: []}
        for name, records, family in sets:
            names, proba, _ = model.answers(records)
            found = doubts(model, records, list(names), None, cross_check=False)
            rejected = [i for i, d in enumerate(found) if d["unknown_why"] == NOT_PROFILE]
            profiles = _profiles([records[i] for i in rejected]) if rejected else {}
            renamed = Counter()
            for k, i in enumerate(rejected):
                engine = contact_check._engine(records[i])
                if names[i] == "sphere" and np.isfinite(profiles["torus"][k]):
                    margins[family].append(profiles["torus"][k])
                for j in np.argsort(-proba[i]):  # the likeliest family whose checks pass
                    f = classes[j]
                    axis = check.threshold(engine, f)
                    close = limit.get(engine) if f == "torus" else \
                        check.threshold(engine, f, check.profile)  # fmt: skip
                    if f == names[i] or axis is None or close is None:
                        continue
                    if found[i]["axis_residual_mm"] / 1000 <= axis and \
                            profiles[f][k] <= close:  # fmt: skip
                        renamed[f] += 1
                        break
            named = [i for i, (n, d) in enumerate(zip(names, found, strict=True))
                     if n == "torus" and not d["unknown"]]  # fmt: skip
            over = sum(v is not None and v > limit.get(contact_check._engine(records[i]), np.inf)
                       for i, v in zip(named, torus_residuals([records[i] for i in named]),
                                       strict=True))  # fmt: skip
            spheres = sum(names[i] == "sphere" for i in rejected)
            print(f"replicate {doc_rep} {name}: rejected spheres {spheres}; "
                  f"any-family renames {sum(renamed.values())} {dict(renamed)}; "
                  f"torus check on {len(named)} torus answers: {over} unknown")  # fmt: skip
        for family, values in margins.items():
            if values:
                print(f"replicate {doc_rep}: rejected spheres' torus residuals, "
                      f"{'in family' if family else 'out of family'}: "
                      f"{1000 * min(values):.2f}-{1000 * max(values):.2f} mm (n={len(values)}, "
                      f"{sum(v > 0.001 for v in values)} above 1 mm)")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
