"""The robustness matrix pooled over replicate runs: every method's columns over all the runs'
grasps, scored by the declared rule (docs/robustness.md, the pooled rule), and its winner.

    python benchmarks/pooled_matrix.py OUT4 OUT5 OUT6 OUT7 OUT8 [--table pooled.md]

Each OUT is a ``tactile-bullet benchmark --protocol robustness --scale full --replicate K``
folder; ``tools/make_default_model.py --matrix OUT8 --pool OUT4,...`` ships the same winner.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments import robustness as R


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="replicate runs' --out folders")
    ap.add_argument("--table", help="also write the pooled table (Markdown) here")
    args = ap.parse_args(argv)
    provenance(argv)
    docs = [json.loads((Path(p) / "robustness.json").read_text()) for p in args.runs]
    replicates = [int(d["config"].get("replicate", 0)) for d in docs]
    if len(set(replicates)) != len(docs):
        ap.error(f"the runs repeat a replicate: {replicates}")
    rows = R.pooled([d["rows"] for d in docs])
    best = R.winner(rows)
    text = R.table_text(rows, best)
    print(f"replicates {', '.join(map(str, sorted(replicates)))}: {len(rows)} rows")
    print(text)
    if best is not None:
        print(f"winner by the declared rule: {best['method']} ({best['training']}), worst "
              f"column {100 * best['score']:.1f}%, mean {100 * best['mean']:.1f}%")  # fmt: skip
    if args.table:
        Path(args.table).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
