"""Keep the first N grasps of each shape of a dataset: a hand's calibration grasps.

``tactile-bullet calibrate`` fits a hand from every grasp of ``--data``; to measure what a few
grasps per shape give (docs/doubt.md, docs/calibration.md) this writes the first ``--per-shape``
grasps of each shape that touched their object (in the dataset's order) to a new record folder;
``--skip K`` passes over each shape's first K such grasps first (the test grasps that follow a
calibration pool).

Usage: python benchmarks/first_per_shape.py DATA --per-shape 10 --out KNOWN [--skip 0]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.datasets.bulk import save_records
from tactile_bullet.experiments.workflow import records_from


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data")
    ap.add_argument("--per-shape", type=int, required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--skip", type=int, default=0, help="each shape's first grasps passed over")
    args = ap.parse_args()
    provenance()
    if args.per_shape < 1 or args.skip < 0:
        sys.exit("--per-shape must be at least 1 and --skip at least 0")
    out = Path(args.out)
    if out.exists() and any(out.iterdir()):
        sys.exit(f"{out} is not empty: name a new folder")
    seen: dict[str, int] = {}
    passed: dict[str, int] = {}
    kept = []
    for rec in records_from(args.data):
        if "no_contact" in rec.flags or seen.get(rec.shape, 0) >= args.per_shape:
            continue
        if passed.get(rec.shape, 0) < args.skip:
            passed[rec.shape] = passed.get(rec.shape, 0) + 1
            continue
        seen[rec.shape] = seen.get(rec.shape, 0) + 1
        kept.append(rec)
    out.mkdir(parents=True, exist_ok=True)
    save_records(kept, out)
    print(f"{len(kept)} grasps written to {out}: " + ", ".join(f"{n} {s}" for s, n in seen.items()))


if __name__ == "__main__":
    main()
