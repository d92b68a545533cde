"""Which rule answers ``unknown``, set by set and object by object: the shipped default (or
``--model``) on a robustness matrix's cached grasps.

For each out-of-family set, the share answered unknown, by rule (novelty, the axis rule, the
profile rule: docs/doubt.md "Objects of no family") and how many of each object; for each
in-family column asked for (read as the matrix reads it, ``noise`` through joint noise), the
share answered unknown by rule and which grasps (true shape -> the answer, the rule). What
docs/robustness.md's replicate tables break down by rule comes from here.

    python benchmarks/unknown_by_rule.py --cache OUT/data --replicate 5 \\
        --columns mujoco,household,noise
    python benchmarks/unknown_by_rule.py --data DIR   # any labelled dataset, as simulated

``--min-points N`` first refits the model's contact check on its training sets (read from
``--cache``; ``--training``, default the shipped default's) with the profile rule needing N
contact points: the seventh replicate's comparison of 10 against 7.

``--no-torus`` scores the answers as they were before the ninth replicate's change (a sphere
its contacts reject stays a sphere, ``unknown``, instead of the torus that fits them): the
change's own judgement compares a run with it and one without.

``--no-axis-torus`` scores them as they were before the eighteenth replicate's change (a
sphere the *axis* rule rejects stays a sphere, unknown, instead of the torus that fits it:
``contact_check.TORUS_FOR_AXIS_REJECTED``), for that change's judgement.

``--sensor`` also reads each out-of-family set through the ``noise`` column's sensor model (1
deg joint noise, 3 deg calibration bias; contacts moved with their links): what a hand whose
contacts come through its joint sensors would get (docs/robustness.md, the sixth replicate).
"""

from __future__ import annotations

import argparse
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np
from _report import matrix_column, matrix_set, provenance  # first: this checkout ahead

from tactile_bullet.datasets.dataset import read_records
from tactile_bullet.experiments.robustness_sets import (
    COLUMNS,
    FAMILY_OBJECTS,
    NOISE,
    OUT_OF_FAMILY_SETS,
)
from tactile_bullet.learn.default import resolve_model
from tactile_bullet.learn.doubt import NOT_PROFILE, NOT_REVOLUTION, UNLIKE_TRAINING, doubts

RULES = {UNLIKE_TRAINING: "novelty", NOT_REVOLUTION: "axis", NOT_PROFILE: "profile"}


def _answers(model, records):
    names, _, was = model.answers(records)
    names = [str(n) for n in names]
    found = doubts(model, records, names, None, cross_check=False)
    return names, [RULES.get(d["unknown_why"]) for d in found], sum(w is not None for w in was)


def _shares(rules: list) -> str:
    n = len(rules)
    counts = Counter(r for r in rules if r)
    parts = ", ".join(f"{k} {100 * counts[k] / n:.1f}%" for k in ("novelty", "axis", "profile"))
    return f"{len(rules)} grasps, unknown {100 * sum(counts.values()) / n:.1f}% ({parts})"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", help="a robustness matrix's data folder")
    ap.add_argument("--data", help="instead: one labelled dataset, read as simulated")
    ap.add_argument("--replicate", type=int, default=0, help="the run's --replicate")
    ap.add_argument("--columns", default="mujoco,household,noise", help="in-family columns")
    ap.add_argument("--model", default=None, help="a model file (default: the shipped one)")
    ap.add_argument("--seed", type=int, default=0, help="the run's --seed")
    ap.add_argument("--min-points", type=int, default=None,
                    help="refit the contact check with the profile rule needing N points")
    ap.add_argument("--training", default=None,
                    help="with --min-points: the matrix training the model was fitted on")
    ap.add_argument("--sensor", action="store_true",
                    help="also read the out-of-family sets through the noise column's sensors")
    ap.add_argument("--no-torus", action="store_true",
                    help="without the ninth replicate's torus-for-sphere renaming")
    ap.add_argument("--no-axis-torus", action="store_true",
                    help="without the eighteenth replicate's renaming of axis-rejected spheres")
    args = ap.parse_args(argv)
    provenance(argv)
    from tactile_bullet.perception import contact_check

    contact_check.TORUS_FOR_SPHERE = not args.no_torus
    contact_check.TORUS_FOR_AXIS_REJECTED = not args.no_axis_torus
    model = resolve_model(args.model)
    if args.data:
        _breakdown("data " + args.data, model, read_records(args.data).records)
        return 0
    if not args.cache:
        ap.error("give --cache (a robustness matrix's data) or --data")
    cache = Path(args.cache)
    if args.min_points is not None:
        model = _refitted(model, cache, args.min_points, args.training)
    from tactile_bullet.learn.perturb import perturb_all

    for name in OUT_OF_FAMILY_SETS:
        simulated = matrix_set(cache, name, args.replicate)
        readings = [("", simulated)]
        if args.sensor:
            readings.append((" through the sensor model", perturb_all(simulated, NOISE, args.seed)))
        for how, records in readings:
            by_object(f"{name}{how}", model, records)
    table = {c.name: c for c in COLUMNS}
    for name in args.columns.split(","):
        records = matrix_column(cache, table[name], args.replicate, args.seed)
        _breakdown(f"column {name}", model, records)
    return 0


def by_object(title: str, model, records) -> None:
    """An out-of-family set's share answered unknown, by rule, then object by object."""
    _, rules, _ = _answers(model, records)
    per: dict[str, list] = defaultdict(list)
    for r, rule in zip(records, rules, strict=True):
        per[(r.mesh or {}).get("name") or r.shape].append(rule)
    print(f"{title}: {_shares(rules)}")
    order = sorted(per, key=lambda k: -np.mean([x is not None for x in per[k]]))
    print("  " + ", ".join(f"{k} {sum(x is not None for x in per[k])}/{len(per[k])}"
                           for k in order))  # fmt: skip


def _refitted(model, cache: Path, min_points: int, training: str | None):
    """``model`` with its contact check fitted again on its training sets, the profile rule
    needing ``min_points`` contact points."""
    from dataclasses import replace

    from tactile_bullet.experiments import robustness as R
    from tactile_bullet.learn.default import default_meta
    from tactile_bullet.learn.novelty import grasp_groups
    from tactile_bullet.perception import profile_fit
    from tactile_bullet.perception.contact_check import ContactCheck

    profile_fit.MIN_POINTS = min_points
    train = R.training_records(cache, "full", training or default_meta()["training"])
    labels = [R.FAMILY_OBJECTS.get(r.shape, r.shape) for r in train]
    return replace(model, axis=ContactCheck.fit(train, labels, grasp_groups(train)))


def _breakdown(title: str, model, records) -> None:
    """In-family grasps: the share answered unknown by rule, and which ones (right or not)."""
    names, rules, renamed = _answers(model, records)
    truths = [FAMILY_OBJECTS.get(r.shape, r.shape) for r in records]  # a household can: cylinder
    wrong = sum(bool(rule) and t != n for t, n, rule in zip(truths, names, rules, strict=True))
    right = np.mean([t == n for t, n in zip(truths, names, strict=True)])
    print(f"{title}: accuracy {100 * right:.1f}%, {renamed} renamed by the contacts; "
          f"{_shares(rules)}; {wrong} of them wrong answers")  # fmt: skip
    which = Counter((t, n, rule) for t, n, rule in zip(truths, names, rules, strict=True)
                    if rule)  # fmt: skip
    for (truth, answer, rule), k in which.most_common():
        print(f"  {k} x {truth} answered {answer}: {rule}")


if __name__ == "__main__":
    raise SystemExit(main())
