"""Picture: the contact rules behind ``unknown``, families against objects of no family, with the
shipped default's thresholds: how far each grasp's contact normals miss their best axis (top)
and its contact points the named family's best surface (bottom).

One column per family (the grasps of the given in-family sets, by their true shape) and one per
object of no family (the given out-of-family sets, by object name), every grasp a dot; the
horizontal marks are the default identifier's thresholds for each family on Bullet
(``perception/contact_check.py``, docs/doubt.md "Objects of no family"). A dot of an object of
no family above the threshold of the family the default names for it is answered ``unknown``;
the figure puts the threshold of its most common name beside it (the bottom panel measures
each grasp against the family it is named). Prints each column's median, largest and
share above.

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
from _report import provenance, save_figure  # first: this checkout ahead of an installed copy

from tactile_bullet.datasets.dataset import read_records
from tactile_bullet.learn.default import default_model
from tactile_bullet.perception.profile_fit import profile_residuals
from tactile_bullet.perception.revolution import axis_residuals


def _collect(records, labels, families, axis, profile) -> None:
    """Each grasp's axis residual and profile residual (against ``families``), in mm, under
    its label."""
    for label, a, p in zip(labels, axis_residuals(records), profile_residuals(records, families),
                           strict=True):  # fmt: skip
        if a is not None:
            axis[label].append(1000 * a)
        if p is not None:
            profile[label].append(1000 * p)


def _panel(ax, columns, families, usual, thresholds) -> None:
    """One column of dots per family, then per object of no family (by falling median), each
    with the threshold of the family it is (usually) named; prints each column's figures."""
    others = sorted(set(columns) - set(families), key=lambda k: -np.median(columns[k]))
    order = [f for f in families if f in columns] + others
    rng = np.random.default_rng(0)
    for i, label in enumerate(order):
        v = np.asarray(columns[label])
        colour = "tab:blue" if label in families else "tab:red"
        ax.scatter(i + rng.uniform(-0.25, 0.25, len(v)), v, s=8, alpha=0.6, color=colour)
        family = label if label in families else usual[label]
        limit = thresholds.get(family)
        if limit is not None:
            ax.hlines(1000 * limit, i - 0.4, i + 0.4, color="black", lw=1.5)
        above = f"{100 * float(np.mean(v > 1000 * limit)):.0f}%" if limit is not None else "-"
        print(f"  {label:18s} n={len(v):3d} median {np.median(v):6.2f} mm, largest "
              f"{v.max():6.2f} mm, above the {family} threshold: {above}")  # fmt: skip
    ticks = [o if o in families else f"{o}\n({usual[o]})" for o in order]
    ax.set_xticks(range(len(order)), ticks, rotation=60, ha="right", fontsize=8)
    ax.set_yscale("log")


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
    family_sets = [read_records(Path(args.cache) / n).records for n in args.family.split(",")]
    other_sets = [read_records(Path(args.cache) / n).records for n in args.other.split(",")]
    named: dict[str, Counter] = defaultdict(Counter)
    axis: dict[str, list[float]] = defaultdict(list)
    profile: dict[str, list[float]] = defaultdict(list)
    for records in family_sets:
        truth = [r.shape for r in records]
        _collect(records, truth, truth, axis, profile)
    families = sorted(axis)
    for records in other_sets:
        answers = [str(a) for a in model.predict_records(records)]
        labels = [(r.mesh or {}).get("name") or r.shape for r in records]
        for label, answer in zip(labels, answers, strict=True):
            named[label][answer] += 1
        _collect(records, labels, answers, axis, profile)
    usual = {o: named[o].most_common(1)[0][0] for o in named}
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(12, 8.5))
    print("axis residual:")
    _panel(top, axis, families, usual, check.thresholds.get("bullet", {}))
    top.set_ylabel("axis residual (mm, RMS)")
    top.set_title("Contact normals against their best axis: families (blue), objects of no "
                  "family (red, the default's usual name below); black: the default's Bullet "
                  "threshold", fontsize=9)  # fmt: skip
    print("profile residual (each grasp against the family it is named):")
    _panel(bottom, profile, families, usual, check.profile.get("bullet", {}))
    bottom.set_ylabel("profile residual (mm, RMS)")
    bottom.set_title("Contact points against the named family's best surface (the torus is not "
                     "modelled); black: the default's Bullet threshold", fontsize=9)  # fmt: skip
    save_figure(fig, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
