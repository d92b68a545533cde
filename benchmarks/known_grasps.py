"""The default method with a few of a hand's own grasps: accuracy on hands written by others.

For each hand column of a robustness matrix (``menagerie``, ``gymnasium``; its grasps replayed
as a hand's CSV; the run's own draw of the set, ``-rK`` for ``--replicate K``), ``--draws``
times: ``k`` grasps per shape are the user's known grasps, the rest the test. Two ways are
scored, each as a user runs it:

- ``train --known``: the default's method (descriptor and classifier of
  ``tactile_bullet/data/default_model.json``) trained on the default's training sets with the
  known grasps added, seconded by the nearest known grasp;
- ``nearest known``: the known grasps alone, one neighbour in ``signature+coupled-joints``
  (``train --data known --descriptor signature+coupled-joints --classifier knn --param
  n_neighbors=1``).

Prints accuracy (mean, min-max over draws) and the shares of wrong and right answers flagged.

Usage: python benchmarks/known_grasps.py --matrix OUT [--cache OUT/data] [--counts 2,5]
       [--draws 4] [--other-hand menagerie=M.xml,gymnasium=G.xml]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments import robustness as R
from tactile_bullet.experiments import workflow
from tactile_bullet.experiments.benchmark import load_set
from tactile_bullet.learn.default import default_meta


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--matrix", required=True)
    ap.add_argument("--cache")
    ap.add_argument("--counts", default="2,5")
    ap.add_argument("--draws", type=int, default=4)
    ap.add_argument("--other-hand", action="append", required=True)
    args = ap.parse_args()
    provenance()
    matrix = Path(args.matrix)
    config = json.loads((matrix / "robustness.json").read_text())["config"]
    cache = Path(args.cache) if args.cache else matrix / "data"
    hands = R.parse_hands(args.other_hand)
    # the run's own replicate of each hand's set (its training sets are every replicate's)
    specs = R.set_specs(config["scale"], hands, None, replicate=int(config.get("replicate", 0)))
    meta = default_meta()
    base = [r for s in R.TRAININGS[meta["training"]] for r in load_set(cache / specs[s].name)[0]]
    for hand in hands:
        print(f"{hand}: {specs[hand].name}", flush=True)
        grasps = R.replayed(load_set(cache / specs[hand].name)[0])
        labels = np.array([r.shape for r in grasps])
        for k in [int(c) for c in args.counts.split(",")]:
            scores = {"train --known": [], "nearest known": []}
            flags = {"train --known": [], "nearest known": []}
            for draw in range(args.draws):
                rng = np.random.default_rng(draw)
                known_idx = np.concatenate([rng.choice(np.flatnonzero(labels == s), k, False)
                                            for s in sorted(set(labels))])  # fmt: skip
                known = [grasps[i] for i in known_idx]
                test = [g for i, g in enumerate(grasps) if i not in set(known_idx)]
                models = {
                    "train --known": workflow.train(base + known, meta["descriptor"],
                                                    meta["classifier"],
                                                    descriptor_params=meta["params"],
                                                    known=known),
                    "nearest known": workflow.train(known, "signature+coupled-joints", "knn",
                                                    params={"n_neighbors": 1}, doubt=False),
                }  # fmt: skip
                for name, model in models.items():
                    doc = workflow.evaluate(model, test)
                    scores[name].append(doc["accuracy"])
                    amb = doc["ambiguous"]
                    flags[name].append((amb.get("wrong_flagged"), amb.get("right_flagged")))
            for name, acc in scores.items():
                wrong = [w for w, _ in flags[name] if w is not None]
                right = [r for _, r in flags[name] if r is not None]
                print(f"{hand:10s} k={k} {name:14s} accuracy {100 * np.mean(acc):.1f} "
                      f"({100 * min(acc):.1f}-{100 * max(acc):.1f}); wrong flagged "
                      f"{100 * np.mean(wrong) if wrong else float('nan'):.0f}%, right flagged "
                      f"{100 * np.mean(right) if right else float('nan'):.0f}%", flush=True)


if __name__ == "__main__":
    main()
