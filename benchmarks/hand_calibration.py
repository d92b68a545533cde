"""Accuracy of the shape fit calibrated from a few grasps of known shape (issue 21 item 3).

Reads grasps made on one hand (a MuJoCo set, a shifted simulator, an imported recording with a
``shape`` column), splits each shape's grasps into a calibration pool (the first half) and a
test set (the rest), and prints the shape fit's accuracy on the test set with: the shipped
Bullet coefficients, no calibration at all (the geometry from the hand's sheet alone: intercept
0, gain 1) and coefficients fitted by ``perception.hand_fit.fit_hand`` (what ``tactile-bullet
calibrate`` runs) from 1, 2, 5 and 10 grasps per shape of the pool (labels only; sizes and
poses fitted; ``--known-sizes``: the records' true sizes given, poses fitted), each count drawn
``--draws`` times.

``--learned`` adds the other way to fit a method to a hand: a registered descriptor (with
parameters as ``name@key=value``) and classifier trained on the same chosen grasps alone
(what ``tactile-bullet train --data KNOWN`` does with them), e.g.
``signature:knn:n_neighbors=1`` (one nearest known grasp); with
``--with-data SIM`` on the simulated grasps of SIM plus the chosen ones (what ``tactile-bullet
train --data SIM --known KNOWN`` does), and with no chosen grasp at all for reference.

``--doubt``: also how many of those answers are flagged ``ambiguous`` as a ``train --known``
model flags them (the margin, and the nearest known grasp as second opinion; docs/doubt.md).

Usage: python benchmarks/hand_calibration.py --data DIR [--draws 2] [--counts 1,2,5,10]
       [--known-sizes]
       [--learned signature:knn:n_neighbors=1,coupled-joints:knn:n_neighbors=1] [--with-data SIM]
       [--skip-shape-fit] [--doubt]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments.workflow import records_from
from tactile_bullet.perception.hand_fit import fit_hand
from tactile_bullet.perception.shape_fit import fit_shape, fitted_shapes
from tactile_bullet.perception.shape_model import Calibration, load_calibration


def accuracy(records, families, cal) -> float:
    names = [fit_shape(r.fci_angles(), families, cal).shape for r in records]
    return float(np.mean([n == r.shape for n, r in zip(names, records, strict=True)]))


def learned_accuracy(
    method: str, chosen, test, simulated=(), cache=None, doubt: dict | None = None
) -> float:
    """``descriptor:classifier[:key=value...]`` trained on ``simulated`` plus ``chosen`` (the
    known grasps, none for a reference), scored on ``test``. ``cache`` (a dict kept across
    calls) holds each descriptor's features of ``simulated`` and ``test``, which every draw
    and count shares: computing the time series of 1,143 grasps once, not once per draw.

    ``doubt`` (a dict, filled in): what ``train --known`` makes of the doubt, the margin
    calibrated on held-out folds and the nearest known grasp as second opinion
    (``learn/doubt.py``), as ``evaluate`` reports it: the wrong and right answers flagged."""
    from transfer_table import descriptor as descriptor_spec  # benchmarks/: name@key=value&...

    from tactile_bullet.learn import doubt as doubts
    from tactile_bullet.learn.models import Model
    from tactile_bullet.plugins import get_classifier

    descriptor, classifier, *params = method.split(":")
    kwargs = {k: int(v) if v.isdigit() else v for k, v in (p.split("=", 1) for p in params)}
    d = descriptor_spec(descriptor)
    cache = {} if cache is None else cache
    if descriptor not in cache:
        x_test = np.asarray(d.transform(test), float)
        x_sim = np.asarray(d.transform(simulated), float) if simulated else x_test[:0]
        cache[descriptor] = x_sim, x_test
    x_sim, x_test = cache[descriptor]
    x = np.vstack([x_sim, np.asarray(d.transform(chosen), float)]) if chosen else x_sim
    model = get_classifier(classifier, **kwargs)
    model.fit(x, [r.shape for r in [*simulated, *chosen]])
    names = np.asarray(model.predict(x_test)).astype(str)
    truth = [r.shape for r in test]
    if doubt is not None and chosen:
        y = [r.shape for r in [*simulated, *chosen]]
        make = lambda: get_classifier(classifier, **kwargs)  # noqa: E731
        reference = doubts.KnownGrasps.from_records(chosen)
        cal = doubts.model_doubt(make, x, np.array(y), None, classifier, reference)
        fitted = Model(d.name, d.params, classifier, kwargs, model, {"doubt": cal}, reference)
        proba = np.asarray(model.predict_proba(x_test), dtype=float)
        found = doubts.evaluation_doubt(fitted, test, truth, names, proba)
        wrong = int(np.sum(names != np.array(truth)))
        doubt["wrong"] = doubt.get("wrong", 0) + wrong
        doubt["wrong_flagged"] = doubt.get("wrong_flagged", 0) + round(
            (found["wrong_flagged"] or 0) * wrong
        )
        doubt.setdefault("right_flagged", []).append(found["right_flagged"] or 0.0)
    return float(np.mean(names == np.array(truth)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--draws", type=int, default=2)
    ap.add_argument("--counts", default="1,2,5,10")
    ap.add_argument("--known-sizes", action="store_true")
    ap.add_argument("--learned", default="", help="descriptor:classifier[:k=v],... to train")
    ap.add_argument("--with-data", help="simulated grasps the --learned methods train on too")
    ap.add_argument("--skip-shape-fit", action="store_true", help="score --learned only")
    ap.add_argument("--doubt", action="store_true", help="also --learned's answers flagged")
    args = ap.parse_args()
    provenance()
    simulated = []
    if args.with_data:
        simulated = [r for r in records_from(args.with_data) if "no_contact" not in r.flags]
    records = [r for r in records_from(args.data)
               if "no_contact" not in r.flags and r.shape in fitted_shapes()]  # fmt: skip
    families = sorted({r.shape for r in records})
    by_shape = {s: [r for r in records if r.shape == s] for s in families}
    pool = {s: v[: len(v) // 2] for s, v in by_shape.items()}
    test = [r for v in by_shape.values() for r in v[len(v) // 2 :]]
    smallest = min(map(len, pool.values()))
    print(f"{args.data}: {len(records)} grasps of {', '.join(families)}; "
          f"pool {sum(map(len, pool.values()))}, test {len(test)}")  # fmt: skip
    methods = [m for m in args.learned.split(",") if m]
    features: dict = {}  # each descriptor's features of the simulated and test grasps
    if not args.skip_shape_fit:
        shipped = accuracy(test, families, load_calibration())
        print(f"shipped Bullet coefficients: {100 * shipped:.1f}%")
        geometry = accuracy(test, families, Calibration())
        print(f"no calibration (geometry alone): {100 * geometry:.1f}%")
    if simulated:
        simulated = [r for r in simulated if r.shape in families]
        for m in methods:
            alone = learned_accuracy(m, [], test, simulated, features)
            print(f"  {m} on {args.with_data} alone: {100 * alone:.1f}%", flush=True)
    rng = np.random.default_rng(0)
    for n in (int(c) for c in args.counts.split(",")):
        if n > smallest:
            print(f"{n} per shape: pool too small ({smallest})")
            continue
        scores, kept, took = [], 0, []
        learned: dict[str, list[float]] = {m: [] for m in methods}
        flags: dict[str, dict] = {m: {} for m in methods}
        for _ in range(args.draws if n < smallest else 1):
            chosen = [v[i] for v in pool.values() for i in rng.choice(len(v), n, replace=False)]
            if not args.skip_shape_fit:
                sizes = [dict(r.params) for r in chosen] if args.known_sizes else None
                t0 = time.perf_counter()
                hand = fit_hand([r.fci_angles() for r in chosen], [r.shape for r in chosen], sizes)
                took.append(time.perf_counter() - t0)
                kept += hand.kept_start
                scores.append(accuracy(test, families, hand.calibration))
            for m in methods:
                learned[m].append(learned_accuracy(
                    m, chosen, test, simulated, features, flags[m] if args.doubt else None
                ))  # fmt: skip
        if scores:
            print(f"{n} per shape: {100 * np.mean(scores):.1f}% "
                  f"(draws: {', '.join(f'{100 * s:.1f}' for s in scores)}; shipped kept in {kept}; "
                  f"calibrate took {np.mean(took):.0f} s)", flush=True)  # fmt: skip
        trained_on = f"{args.with_data} and them" if simulated else "them alone"
        for m, acc in learned.items():
            print(f"  {n} per shape: {m} trained on {trained_on}: {100 * np.mean(acc):.1f}% "
                  f"(draws: {', '.join(f'{100 * a:.1f}' for a in acc)})", flush=True)
            if flags[m]:
                f = flags[m]
                print(f"    ambiguous: {f['wrong_flagged']} of {f['wrong']} wrong answers, "
                      f"{100 * np.mean(f['right_flagged']):.1f}% of right ones", flush=True)


if __name__ == "__main__":
    main()
