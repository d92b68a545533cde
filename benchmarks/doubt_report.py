"""How well the calibrated margin flags wrong answers: the figures of docs/doubt.md.

Reads a benchmark's ``benchmark.json`` (each row carries ``ambiguous``: the shares of all, right
and wrong answers its pair's calibrated margin flags, ``learn/doubt.py``) and pools, per method,
the right and wrong answers of the in-Bullet levels (``in-distribution``) and of the shifted
simulator (every ``sim-shift`` level but ``none``), the stand-in for another engine, and of
the other engine itself (``cross-engine``, both directions).

Usage::

    tactile-bullet benchmark --protocol in-distribution,sim-shift \\
        --descriptor signature,raw-joints,robust-joints --classifier svm,knn,shape-fit \\
        --training clean --out bench-doubt
    python benchmarks/doubt_report.py bench-doubt/benchmark.json

    tactile-bullet benchmark --protocol cross-engine --training clean,randomized --out bench-x
    python benchmarks/doubt_report.py bench-x/benchmark.json
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict

from _report import provenance  # first: this checkout ahead of an installed copy

GROUPS = {"in-Bullet": ("in-distribution", None), "shifted": ("sim-shift", "none"),
          "cross-eng": ("cross-engine", None)}  # fmt: skip
"""Report group -> (protocol, level left out). ``cross-eng`` pools both directions of the
``cross-engine`` protocol (each level's margin calibrated on its own training engine)."""


def pooled(rows: list[dict]) -> dict[tuple, dict[str, dict[str, float]]]:
    """(descriptor, classifier, training) -> group -> counts of right/wrong answers and of
    those flagged."""
    out: dict[tuple, dict[str, dict[str, float]]] = defaultdict(
        lambda: defaultdict(lambda: defaultdict(float))
    )
    for r in rows:
        amb = r.get("ambiguous")
        if r.get("accuracy") is None or not amb:
            continue
        for group, (protocol, skip) in GROUPS.items():
            if r["protocol"] != protocol or r["level"] == skip:
                continue
            n = r["test_records"]
            right = round(r["accuracy"] * n)
            wrong = n - right
            c = out[(r["descriptor"], r["classifier"], r["training"])][group]
            c["right"] += right
            c["wrong"] += wrong
            c["right_flagged"] += (amb["right_flagged"] or 0.0) * right
            c["wrong_flagged"] += (amb["wrong_flagged"] or 0.0) * wrong
            c["margin"] = amb["margin"] if amb["margin"] is not None else float("nan")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("benchmark_json")
    args = ap.parse_args()
    provenance()
    with open(args.benchmark_json) as fh:
        rows = json.load(fh)["rows"]
    table = pooled(rows)
    print(f"{'method':<34} {'group':<10} {'margin':>7} {'accuracy':>9} "
          f"{'wrong flagged':>15} {'right flagged':>15}")  # fmt: skip
    for method, groups in sorted(table.items()):
        for group, c in groups.items():
            n = c["right"] + c["wrong"]
            wf = f"{c['wrong_flagged']:.0f}/{c['wrong']:.0f}"
            if c["wrong"]:
                wf += f" {100 * c['wrong_flagged'] / c['wrong']:.0f}%"
            rf = f"{c['right_flagged']:.0f}/{c['right']:.0f}"
            if c["right"]:
                rf += f" {100 * c['right_flagged'] / c['right']:.1f}%"
            print(f"{' + '.join(method):<34} {group:<10} {c['margin']:7.3f} "
                  f"{100 * c['right'] / n:8.1f}% {wf:>15} {rf:>15}")  # fmt: skip


if __name__ == "__main__":
    main()
