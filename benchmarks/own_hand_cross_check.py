"""The doubt's cross-check with and without our MuJoCo hand's own coefficients
(``learn.doubt.OWN_HAND_COEFFICIENTS``): the shipped default (or ``--model``) evaluated on each
``--data`` set both ways, the same grasps; per set the accuracy, the unknown share, and the
right and wrong answers flagged (the right ones by cause); then the tenth replicate's
declared rule on them (docs/robustness.md, "Declared before the tenth replicate run").

    python benchmarks/own_hand_cross_check.py --data OUT10/data/robust-mujoco-test-r10 \\
        [--data OTHER ...] [--model M.npz]
"""

from __future__ import annotations

import argparse
from collections import Counter

from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.console import reporting
from tactile_bullet.datasets.dataset import read_records
from tactile_bullet.experiments.training import evaluate
from tactile_bullet.learn import doubt
from tactile_bullet.learn.default import resolve_model
from tactile_bullet.learn.doubt import doubts


def counts(doc: dict) -> dict:
    """Right and wrong answers flagged (counts), accuracy and the unknown share."""
    n, acc = doc["records"], doc["accuracy"]
    right = round(acc * n)
    amb = doc["ambiguous"]
    return {"n": n, "accuracy": acc, "unknown": doc["unknown"]["in_family"],
            "right": right, "wrong": n - right,
            "right_flagged": round((amb["right_flagged"] or 0) * right),
            "wrong_flagged": round((amb["wrong_flagged"] or 0) * (n - right))}  # fmt: skip


def causes(model, records) -> Counter:
    """Why each right answer is flagged: ``unknown``, ``cross-check reads X``, ``renamed``
    (the contacts overruled the classifier) or ``margin``."""
    names, proba, renamed_from = model.answers(records)
    found = doubts(model, records, [str(n) for n in names], proba, renamed_from=renamed_from)
    out = Counter()
    for rec, name, doc in zip(records, names, found, strict=True):
        if str(name) != rec.shape:
            continue
        if doc["unknown"]:
            out["unknown"] += 1
        elif doc["ambiguous"] and doc["cross_check"] not in (None, str(name)):
            out[f"cross-check reads {doc['cross_check']}"] += 1
        elif doc["ambiguous"] and doc["renamed_from"]:
            out["renamed"] += 1
        elif doc["ambiguous"]:
            out["margin"] += 1
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", action="append", required=True, help="a labelled dataset")
    ap.add_argument("--model", help="a model file (default: the shipped default)")
    args = ap.parse_args(argv)
    provenance(argv)
    model = resolve_model(args.model)
    for path in args.data:
        records = read_records(path).records
        got = {}
        for label, on in (("without", False), ("with", True)):
            doubt.OWN_HAND_COEFFICIENTS = on
            with reporting(False):
                got[label] = counts(evaluate(model, records))
                why = causes(model, records)
            c = got[label]
            print(f"{path} {label:8s}: {c['n']} grasps, accuracy {100 * c['accuracy']:.1f}%, "
                  f"unknown {100 * c['unknown']:.1f}%, right answers flagged "
                  f"{c['right_flagged']}/{c['right']}, wrong answers flagged "
                  f"{c['wrong_flagged']}/{c['wrong']}")  # fmt: skip
            print("  right answers flagged, by cause: "
                  + ", ".join(f"{k} {v}" for k, v in sorted(why.items())))
        a, b = got["without"], got["with"]
        if a == b:
            print("  the same both ways: no grasp of our MuJoCo hand here")
            continue
        rule = (b["right_flagged"] < a["right_flagged"],
                b["wrong_flagged"] >= a["wrong_flagged"] - 1,
                (b["accuracy"], b["unknown"]) == (a["accuracy"], a["unknown"]))
        print(f"  (a) fewer right answers flagged: {rule[0]}; (b) wrong answers flagged fall "
              f"by at most one: {rule[1]}; (c) accuracy and unknown unchanged: {rule[2]} -> "
              f"{'kept' if all(rule) else 'reverted'}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
