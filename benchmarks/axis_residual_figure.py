"""Picture: how far a grasp's contact normals miss their best axis, families against objects of
no family, with the shipped default's thresholds.

One column per family (the grasps of the given in-family sets, by their true shape) and one per
object of no family (the given out-of-family sets, by object name), every grasp a dot; the
horizontal marks are the default identifier's axis thresholds for each family on Bullet
(``perception/revolution.py``, docs/doubt.md "Objects of no family"). A dot of an object of no
family above the threshold of the family the default names for it is answered ``unknown``;
the figure puts the threshold of its most common name beside it. Prints each column's median
and share above.

    python benchmarks/axis_residual_figure.py --cache OUT/data \\
        --family robust-bullet-train-randomized,robust-bullet-posed-randomized \\
        --other robust-out-of-family-r4,robust-out-of-family-validation-r4 \\
        --out docs/img/axis_residuals.png
"""

from __future__ import annotations

import argparse
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.datasets.dataset import read_records
from tactile_bullet.learn.default import default_model
from tactile_bullet.perception.revolution import axis_residuals


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", required=True, help="a robustness matrix's data folder")
    ap.add_argument("--family", required=True, help="in-family sets, comma-separated")
    ap.add_argument("--other", required=True, help="out-of-family sets, comma-separated")
    ap.add_argument("--out", default="docs/img/axis_residuals.png")
    args = ap.parse_args(argv)
    provenance(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    model = default_model()
    check = model.axis
    columns: dict[str, list[float]] = defaultdict(list)
    named: dict[str, Counter] = defaultdict(Counter)
    for name in args.family.split(","):
        records = read_records(Path(args.cache) / name).records
        for r, v in zip(records, axis_residuals(records), strict=True):
            if v is not None:
                columns[r.shape].append(1000 * v)
    families = sorted(columns)
    for name in args.other.split(","):
        records = read_records(Path(args.cache) / name).records
        answers = model.predict_records(records)
        for r, v, a in zip(records, axis_residuals(records), answers, strict=True):
            label = (r.mesh or {}).get("name") or r.shape
            if v is not None:
                columns[label].append(1000 * v)
                named[label][str(a)] += 1
    others = sorted(set(columns) - set(families), key=lambda k: -np.median(columns[k]))
    order = [*families, *others]
    fig, ax = plt.subplots(figsize=(12, 4.8))
    rng = np.random.default_rng(0)
    for i, label in enumerate(order):
        v = np.asarray(columns[label])
        colour = "tab:blue" if label in families else "tab:red"
        ax.scatter(i + rng.uniform(-0.25, 0.25, len(v)), v, s=8, alpha=0.6, color=colour)
        family = label if label in families else named[label].most_common(1)[0][0]
        limit = check.threshold("bullet", family)
        if limit is not None:
            ax.hlines(1000 * limit, i - 0.4, i + 0.4, color="black", lw=1.5)
        above = float(np.mean(v > 1000 * limit)) if limit is not None else float("nan")
        print(f"{label:18s} n={len(v):3d} median {np.median(v):5.2f} mm, above the "
              f"{family} threshold: {100 * above:.0f}%")  # fmt: skip
    ticks = [o if o in families else f"{o}\n({named[o].most_common(1)[0][0]})" for o in order]
    ax.set_xticks(range(len(order)), ticks, rotation=60, ha="right", fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("axis residual (mm, RMS)")
    ax.set_title("Contact normals against their best axis: families (blue), objects of no family "
                 "(red, the default's usual name below); black: the default's Bullet threshold",
                 fontsize=9)  # fmt: skip
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
