"""The active protocol pooled over seeds: planned against random next poses, object by object.

Each OUT is a ``tactile-bullet benchmark --protocol active --out OUT`` folder (one seed each);
every run scores its strategies on the same objects, so planned and random are compared in
pairs. Prints, per column and strategy, the objects right after 1, 2 and 3 grasps summed over
the runs; then, per column, planned minus random after 2 grasps in points, with the objects
only one of the two gets right (planned only / random only) and the two-sided sign test's p
of those discordant pairs (scipy's exact binomial test, half each under no difference).

    python benchmarks/active_pooled.py OUT1 OUT2 ... [--grasps 2]

An OUT may also be the ``--json`` file of ``benchmarks/active_switch.py ... --random``: its
switch-off arm is the planned strategy as it stood, its random arm the random one. Runs written
before rows kept each object's answers (``right``) are refused; runs of the same seed are
refused (they are the same objects).
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

from _report import provenance  # first: this checkout ahead of an installed copy


def sign_test(a: int, b: int) -> float:
    """Two-sided exact sign test of ``a`` against ``b`` discordant pairs (1.0 with none):
    scipy's exact binomial test at one half."""
    from scipy.stats import binomtest

    return 1.0 if a + b == 0 else float(binomtest(a, a + b, 0.5).pvalue)


def pooled(docs: list[dict]) -> tuple[dict, dict]:
    """(counts, pairs): counts[(column, strategy)] = [objects, right after k grasps...];
    pairs[column] = list of (planned right, random right) per grasp count, object by object."""
    counts: dict = {}
    pairs: dict = defaultdict(list)
    for doc in docs:
        by = {(r["column"], r["strategy"]): r for r in doc["rows"]}
        for (column, strategy), row in by.items():
            right = row["right"]
            depth = len(right[0]) if right else 0
            c = counts.setdefault((column, strategy), [0] + [0] * depth)
            c[0] += len(right)
            for k in range(min(depth, len(c) - 1)):
                c[k + 1] += sum(bool(r[k]) for r in right)
        for column in {c for c, _ in by}:
            planned, random = by.get((column, "planned")), by.get((column, "random"))
            if planned and random and len(planned["right"]) == len(random["right"]):
                pairs[column].extend(zip(planned["right"], random["right"], strict=True))
    return counts, pairs


def read_run(path: Path) -> dict:
    """An ``active`` run's ``active.json`` (``path`` its folder), or an ``active_switch.py
    --random --json`` file as such a run: its switch-off arm planned, its random arm random."""
    if path.is_dir():
        return json.loads((path / "active.json").read_text())
    doc = json.loads(path.read_text())
    rows = [{"column": column, "strategy": strategy, **arms[arm]}
            for column, arms in doc["rows"].items()
            for strategy, arm in (("planned", "without"), ("random", "random")) if arm in arms]
    return {"config": {"seed": doc["seed"]}, "rows": rows}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="active runs' --out folders (or active_switch "
                    "--json files), one seed each")
    ap.add_argument("--grasps", type=int, default=2, help="the grasp count compared (1-3)")
    args = ap.parse_args(argv)
    provenance(argv)
    docs = [read_run(Path(p)) for p in args.runs]
    seeds = [d["config"].get("seed") for d in docs]
    if len(set(seeds)) != len(seeds):
        ap.error(f"the runs repeat a seed: {seeds}")
    if any("right" not in r for d in docs for r in d["rows"]):
        ap.error("a run's rows keep no per-object answers (written before they did): rerun it")
    counts, pairs = pooled(docs)
    print(f"seeds {', '.join(map(str, seeds))}")
    print(f"{'column':14s} {'strategy':18s} {'objects':>7s}  right after 1 / 2 / 3 grasps")
    for (column, strategy), c in sorted(counts.items()):
        shares = " / ".join(f"{k} ({100 * k / c[0]:.1f}%)" for k in c[1:])
        print(f"{column:14s} {strategy:18s} {c[0]:7d}  {shares}")
    k = args.grasps - 1
    print(f"\nplanned - random after {args.grasps} grasps, object by object:")
    for column, both in sorted(pairs.items()):
        only_planned = sum(1 for p, r in both if p[k] and not r[k])
        only_random = sum(1 for p, r in both if r[k] and not p[k])
        gain = 100.0 * (only_planned - only_random) / len(both)
        print(f"{column:14s} {gain:+6.1f} points over {len(both)} objects; planned only "
              f"{only_planned}, random only {only_random}; sign test p = "
              f"{sign_test(only_planned, only_random):.3f}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
