"""``adapt`` on hands written by others: what it chooses, what it expects, what it then scores.

For each hand column of a robustness matrix's cache (``menagerie``, ``gymnasium``; its grasps
replayed as a hand's CSV, as ``benchmarks/known_grasps.py`` reads them), ``--draws`` times:
``k`` grasps per shape are the user's known grasps, the rest are the test. ``adapt`` scores its
candidate ways on the known grasps alone (tactile_bullet/experiments/adapt.py) and keeps one;
the model it writes is then scored on the test grasps, which it never saw. Prints, per hand and
k and draw: the way chosen, adapt's expected accuracy and 95% interval, the accuracy on the test
grasps, and each way's cross-validated accuracy; then per hand and k the means over draws.

Usage: python benchmarks/adapt_hands.py --cache OUT/data [--counts 2,5] [--draws 5]
       [--hands menagerie,gymnasium] [--calibrate] [--replicate K]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments import robustness as R
from tactile_bullet.experiments import workflow
from tactile_bullet.experiments.adapt import adapt, build
from tactile_bullet.experiments.benchmark import load_set


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", required=True, help="a robustness matrix's data folder")
    ap.add_argument("--counts", default="2,5")
    ap.add_argument("--draws", type=int, default=5)
    ap.add_argument("--hands", default="menagerie,gymnasium")
    ap.add_argument("--replicate", type=int, default=0,
                    help="the matrix run's --replicate: read its own draw of each hand's set")
    ap.add_argument("--calibrate", action="store_true",
                    help="adapt --calibrate: the calibrated shape fit among the ways")
    args = ap.parse_args()
    provenance()
    cache = Path(args.cache)
    for hand in args.hands.split(","):
        suffix = f"-r{args.replicate}" if args.replicate else ""
        folder = next(cache.glob(f"*-{hand}{suffix}"), None)
        if folder is None:
            raise SystemExit(f"no {hand} set '*-{hand}{suffix}' in {cache}: give the matrix "
                             "run's --replicate, and --other-hand when it was run")  # fmt: skip
        print(f"{hand}: {folder.name}", flush=True)
        grasps = R.replayed(load_set(folder)[0])
        labels = np.array([r.shape for r in grasps])
        for k in [int(c) for c in args.counts.split(",")]:
            chosen, expected, unseen = [], [], []
            for draw in range(args.draws):
                rng = np.random.default_rng(draw)
                idx = set(np.concatenate([rng.choice(np.flatnonzero(labels == s), k, False)
                                          for s in sorted(set(labels))]).tolist())  # fmt: skip
                known = [g for i, g in enumerate(grasps) if i in idx]
                test = [g for i, g in enumerate(grasps) if i not in idx]
                start = time.perf_counter()
                doc = adapt(known, seed=draw, calibrate=args.calibrate)
                model = build(doc["chosen"], known)
                took = time.perf_counter() - start
                scored = workflow.evaluate(model, test)["accuracy"]
                lo, hi = doc["interval"]
                ways = ", ".join(f"{w['way']} {100 * w['accuracy']:.0f}" for w in doc["ways"])
                print(f"{hand:10s} k={k} draw {draw}: chose {doc['chosen']}, expected "
                      f"{100 * doc['accuracy']:.1f}% (95% {100 * lo:.0f}-{100 * hi:.0f}), on "
                      f"{len(test)} unseen grasps {100 * scored:.1f}%; CV: {ways}; "
                      f"{took:.0f} s", flush=True)  # fmt: skip
                chosen.append(doc["chosen"])
                expected.append(doc["accuracy"])
                unseen.append(scored)
            picks = ", ".join(f"{w} {chosen.count(w)}" for w in sorted(set(chosen)))
            print(f"{hand:10s} k={k} over {args.draws} draws: chose {picks}; expected "
                  f"{100 * np.mean(expected):.1f}%, on unseen grasps {100 * np.mean(unseen):.1f}% "
                  f"({100 * min(unseen):.1f}-{100 * max(unseen):.1f})", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
