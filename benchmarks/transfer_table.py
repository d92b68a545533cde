"""Headline accuracy of a few methods on the benchmark's protocols, read from its grasp cache.

``tactile-bullet benchmark`` also calibrates each pair's doubt margin (a shape fit per held-out
grasp), which takes most of its time on a loaded machine. This tool reuses the sets a benchmark
run simulated (its ``--cache``, default ``OUT/data``), fits each method exactly as the benchmark
does (same records, same ``noise-aware`` augmentation, same sensor perturbation seeds) and
prints every level's accuracy, so the benchmark's ``accuracy`` figures come out the same in
seconds. It does not simulate: a set missing from the cache is an error naming it (run the
benchmark with those protocols and trainings once first).

Usage::

    tactile-bullet benchmark --protocol cross-engine --training clean,randomized --out B
    python benchmarks/transfer_table.py --cache B/data --protocol cross-engine \\
        --method time-series:random-forest,signature:svm,signature@level=true:svm \\
        --training clean,randomized
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.errors import UsageError
from tactile_bullet.experiments import protocols as P
from tactile_bullet.experiments.benchmark import level_seed, load_set
from tactile_bullet.experiments.workflow import labels_of
from tactile_bullet.learn.perturb import perturb_all
from tactile_bullet.learn.robust import augment
from tactile_bullet.plugins import get_classifier, get_descriptor


def descriptor(spec: str):
    """``name`` or ``name@key=value&key=value`` (a variant with parameters, e.g.
    ``signature@level=true``; values read as JSON, else kept as text)."""
    import json

    name, _, rest = spec.partition("@")
    params = {}
    for item in filter(None, rest.split("&")):
        key, _, value = item.partition("=")
        try:
            params[key] = json.loads(value)
        except ValueError:
            params[key] = value
    return get_descriptor(name, **params)


def accuracy_rows(cache: Path, protocols: list[str], methods: list[tuple[str, str]],
                  trainings: list[str], scale: str = "full", seed: int = 0,
                  doubt: bool = False, j0: bool = False,
                  hands: dict | None = None) -> list[dict]:  # fmt: skip
    """One row per (protocol, level, descriptor, classifier, training), as the benchmark's;
    with ``doubt`` also its ``ambiguous`` shares, calibrated as the benchmark calibrates them
    (slow: a shape fit per held-out training grasp and per test grasp). ``j0``: the test
    grasps read as a hand that publishes only J0 = J1 + J2 is imported (``coupled.j0_only``).
    ``hands``: engine -> shape-fit ``Calibration``: the cross-check reads each engine's grasps
    (held-out training grasps and test grasps alike) with that engine's hand calibration, as
    ``--hand-calibration`` has it read a hand's (the shipped coefficients for the others)."""
    from tactile_bullet.experiments.benchmark import _scored
    from tactile_bullet.learn.doubt import calibrate_margin, cross_check_accepts
    from tactile_bullet.perception.shape_model import use_calibration

    def hand_of(recs: list):
        """The hand calibration of ``recs``' engine (None: the shipped coefficients)."""
        engines = {r.controller.engine for r in recs}
        return (hands or {}).get(engines.pop()) if len(engines) == 1 else None

    table = P.protocols(scale)
    loaded: dict[str, list] = {}
    seconds_of: dict[str, np.ndarray] = {}

    def records(name: str) -> list:
        if name not in loaded:
            if not (cache / name).exists():
                raise UsageError(f"set {name} is not in {cache}: run the benchmark with it first")
            loaded[name] = load_set(cache / name)[0]
        return loaded[name]

    rows = []
    for name in protocols:
        protocol = table[name]
        for level in protocol.levels:
            test = [r for t in level.test for r in records(t)]
            if not level.sensor.is_clean:
                test = perturb_all(test, level.sensor, level_seed(name, level.name, seed))
            if j0:
                from tactile_bullet.learn.coupled import j0_only

                test = [j0_only(r) for r in test]
            y_test = labels_of(test).astype(str)
            for desc, clf in methods:
                d = descriptor(desc)
                x_test = np.asarray(d.transform(test), float)
                for training in trainings:
                    parts = P.train_sets(level.train or protocol.train)
                    if training == "randomized":
                        parts = [P.randomized_name(p) for p in parts]
                    train = [r for p in parts for r in records(p)]
                    if training == "noise-aware":
                        train = augment(train, seed=seed)
                    x, y = np.asarray(d.transform(train), float), labels_of(train)
                    model = get_classifier(clf).fit(x, y)
                    pred = np.asarray(model.predict(x_test)).astype(str)
                    ambiguous = None
                    if doubt:
                        with use_calibration(hand_of(train)):
                            calibration = calibrate_margin(lambda c=clf: get_classifier(c), x, y,
                                                           seed=seed, records=train,
                                                           classifier=clf)  # fmt: skip
                        second = None
                        if calibration["cross_check"] is not None:
                            key = f"{name}/{level.name}"
                            if key not in seconds_of:
                                classes = sorted(str(c) for c in model.classes_)
                                with use_calibration(hand_of(test)):
                                    seconds_of[key] = cross_check_accepts(test, classes)
                            second = seconds_of[key]
                        pred, ambiguous = _scored(model, x_test, y_test, calibration, second)
                    rows.append({"protocol": name, "level": level.name, "descriptor": desc,
                                 "classifier": clf, "training": training,
                                 "headline": level.headline, "test_records": len(test),
                                 "accuracy": float(np.mean(pred == y_test)),
                                 "ambiguous": ambiguous})  # fmt: skip
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", required=True, type=Path, help="a benchmark's grasp cache")
    ap.add_argument("--protocol", default="cross-engine", help="comma list")
    ap.add_argument("--method", required=True, help="comma list of descriptor:classifier")
    ap.add_argument("--training", default="clean", help="comma list")
    ap.add_argument("--scale", default="full")
    ap.add_argument("--all-levels", action="store_true", help="every level, not headlines")
    ap.add_argument("--doubt", metavar="FILE.json",
                    help="also calibrate each method's margin and write the rows, with their "
                         "'ambiguous' shares, as a benchmark.json for benchmarks/doubt_report.py")
    ap.add_argument("--j0-only", action="store_true",
                    help="read the test grasps as a hand publishing only J0 = J1 + J2")
    ap.add_argument("--hand-calibration", action="append", default=[], metavar="ENGINE=FILE",
                    help="the cross-check reads ENGINE's grasps with this hand calibration "
                         "(tactile-bullet calibrate's file); repeatable")
    args = ap.parse_args()
    provenance()
    from tactile_bullet.realhand.hand_calibration import load

    hands = {}
    for item in args.hand_calibration:
        engine, sep, path = item.partition("=")
        if not sep:
            ap.error(f"--hand-calibration takes ENGINE=FILE, got {item!r}")
        hands[engine] = load(path).calibration
    methods = [tuple(m.split(":", 1)) for m in args.method.split(",")]
    rows = accuracy_rows(args.cache, P.resolve(args.protocol), methods,
                         args.training.split(","), args.scale, doubt=bool(args.doubt),
                         j0=args.j0_only, hands=hands)  # fmt: skip
    if args.doubt:
        import json

        Path(args.doubt).write_text(json.dumps({"rows": rows}, indent=1))
    for r in rows:
        if r["headline"] or args.all_levels or r["protocol"] == "cross-engine":
            print(f"{r['protocol']:<14} {r['level']:<16} {r['descriptor']:<30} "
                  f"{r['classifier']:<14} {r['training']:<12} {100 * r['accuracy']:5.1f} "
                  f"({r['test_records']})", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
