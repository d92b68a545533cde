"""Which grasp quantities survive a change of the J1/J2 coupling, and what that does to methods.

Reads the benchmark's sets (``tactile-bullet benchmark --protocol coupling-shift --training
clean,randomized --out DIR``: they live in DIR/data, or ``--cache``), which hold the same grasp
specs made with three tendon rules (``sim/coupling.py``): the held-out test set (j2-first, as
every training set) and its ``coupling-equal-torque`` / ``coupling-distal-first`` twins.

1. Invariance: per quantity, the mean absolute change from the j2-first grasp to the same grasp
   under another rule, over the quantity's spread across the test set (std): under ~0.3 a
   quantity survives the change, near 1 or above it is rewritten by it.
2. Accuracy: each descriptor + classifier trained on the clean and on the randomised training
   set (and on the randomised set with its drawn joint reading offsets taken off again,
   ``randomized-no-offsets``: what the offsets alone cost), tested on the held-out grasps as
   simulated, as a J0-only hand would be imported (``learn/coupled.j0_only``), and under each
   other coupling rule.

    python benchmarks/bench_coupling.py --data DIR/data [--scale quick] [--descriptors a,b]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

DESCRIPTORS = ("signature", "coupled-signature", "raw-joints", "coupled-joints",
               "time-series", "coupled-time-series")  # fmt: skip


def spec_key(r):
    return (r.shape, tuple(sorted(r.params.items())), r.pose.offset, r.pose.rotation)


def quantities(r) -> dict[str, np.ndarray]:
    from tactile_bullet.learn.descriptors import SignatureDescriptor

    a = r.fci_angles()
    sig = SignatureDescriptor().transform([r])[0]
    return {
        "J3": a[0], "J2": a[1], "J1": a[2], "J0 = J1 + J2": a[1] + a[2],
        "J3 + J0 (whole finger)": a.sum(axis=0),
        "signature lower line": sig[:10], "signature upper line": sig[10:20],
        "signature bulges": sig[20:22],
        "J3 series (32 instants)": _series(r, 0), "J0 series (32 instants)": _series(r, 1),
        "J2 series (32 instants)": _series(r, 2),
    }  # fmt: skip


def _series(r, which: int) -> np.ndarray:
    from tactile_bullet.learn.time_series import resample_series

    s = r.fci_series()  # (T, 3, 4)
    values = {0: s[:, 0], 1: s[:, 1] + s[:, 2], 2: s[:, 1]}[which]
    return resample_series(r.time, values, 32).ravel()


def invariance(base, other) -> dict[str, float]:
    pairs = {spec_key(r): r for r in base}
    matched = [(pairs[spec_key(r)], r) for r in other if spec_key(r) in pairs]
    out = {}
    for name in quantities(matched[0][0]):
        a = np.array([quantities(x)[name] for x, _ in matched])
        b = np.array([quantities(y)[name] for _, y in matched])
        spread = float(np.std(a, axis=0).mean())
        out[name] = float(np.abs(a - b).mean()) / spread if spread > 0 else float("nan")
    return out


def without_offsets(r):
    """The record with the reading offsets its grasp drew taken off (the simulator knows them)."""
    import dataclasses

    from tactile_bullet.records import OFFSET_JOINTS

    if not r.controller.joint_offsets:
        return r
    shift = np.zeros(len(r.joint_names))
    shift[[r.joint_index(n) for n in OFFSET_JOINTS]] = r.controller.joint_offsets
    return dataclasses.replace(r, angles=r.angles - shift, final_angles=r.final_angles - shift)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="the benchmark's cache folder")
    parser.add_argument("--scale", default="full", choices=("full", "quick", "tiny"))
    parser.add_argument("--descriptors", default=",".join(DESCRIPTORS))
    parser.add_argument("--classifier", default="svm")
    args = parser.parse_args()
    provenance()

    from tactile_bullet.experiments import protocols as P
    from tactile_bullet.experiments.benchmark import load_set
    from tactile_bullet.experiments.workflow import labels_of
    from tactile_bullet.learn.coupled import j0_only
    from tactile_bullet.plugins import get_classifier, get_descriptor

    tag = "" if args.scale == "full" else f"{args.scale}-"
    root = Path(args.data)

    def read(name):
        return load_set(root / name)[0]

    test = read(f"{tag}demo-test")
    rules = {rule: read(f"{tag}coupling-{rule}") for rule in P.COUPLING_SHIFTS}
    print(f"invariance: mean |change| / spread across the {len(test)} test grasps")
    table = {rule: invariance(test, recs) for rule, recs in rules.items()}
    print(f"  {'quantity':28s}" + "".join(f"{rule:>14s}" for rule in rules))
    for name in table[P.COUPLING_SHIFTS[0]]:
        print(f"  {name:28s}" + "".join(f"{table[r][name]:14.2f}" for r in rules))

    randomized = read(P.randomized_name(f"{tag}demo-train"))
    trains = {"clean": read(f"{tag}demo-train"), "randomized": randomized,
              "randomized-no-offsets": [without_offsets(r) for r in randomized]}  # fmt: skip
    tests = {"held-out": test, "held-out J0-only": [j0_only(r) for r in test]}
    for rule, recs in rules.items():
        tests[rule] = recs
    tests["distal-first J0-only"] = [j0_only(r) for r in rules["distal-first"]]
    print(f"\naccuracy (%), {args.classifier}; test grasps: "
          + ", ".join(f"{k} {len(v)}" for k, v in tests.items()))  # fmt: skip
    print(f"  {'descriptor':22s}{'training':23s}" + "".join(f"{k:>22s}" for k in tests))
    for name in args.descriptors.split(","):
        desc = get_descriptor(name)
        for training, records in trains.items():
            model = get_classifier(args.classifier).fit(desc.transform(records),
                                                        labels_of(records))  # fmt: skip
            cells = []
            for recs in tests.values():
                pred = np.asarray(model.predict(desc.transform(recs))).astype(str)
                cells.append(100.0 * float(np.mean(pred == labels_of(recs))))
            print(f"  {name:22s}{training:23s}" + "".join(f"{c:22.1f}" for c in cells))


if __name__ == "__main__":
    main()
