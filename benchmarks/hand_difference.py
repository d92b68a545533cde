"""Which descriptors survive a change of hand: the same objects grasped by two hands.

Reads a simulated set made by one hand (e.g. ``benchmarks/other_hand_sets.py --hand independent``
with a hand written by others) and grasps every one of its objects again, same shape, sizes,
pose and seed, with our own hand on ``--engine``; or, with ``--other``, reads a second set of
the same objects (matched by shape and seed). For each descriptor it prints how far the
features move from one hand to the other, in units of how far they spread across objects:
for each feature, the mean absolute change over the matched grasps divided by the feature's
standard deviation over the reference hand's grasps, then the median over the descriptor's
features. Under ~0.3 the descriptor reads the other hand's grasp of an object much as ours;
near 1 the change is as large as the difference between objects (docs/transfer.md's table
across tendon rules is the same measure).

    python benchmarks/hand_difference.py --data HAND-SET --engine mujoco [--servo-stiffness 1]
    python benchmarks/hand_difference.py --data HAND-SET --other OTHER-SET
"""

from __future__ import annotations

import argparse

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.datasets.bulk import GraspSpec, simulate_many
from tactile_bullet.experiments.workflow import records_from
from tactile_bullet.plugins import get_descriptor
from tactile_bullet.records import ControllerSettings

DESCRIPTORS = (
    "raw-joints", "coupled-joints", "signature", "coupled-signature", "finger-points",
    "coupled-finger-points",
)  # fmt: skip


def ours(records, engine: str, workers: int, servo_stiffness: float = 0.0) -> list:
    """The same objects (shape, sizes, pose, seed) grasped by our hand on ``engine``
    (``servo_stiffness``: ``ControllerSettings``', 0 our hand's own)."""
    ctl = ControllerSettings(engine=engine, servo_stiffness=servo_stiffness)
    specs = [GraspSpec(r.shape, dict(r.params), r.pose, int(r.seed), ctl) for r in records]
    made, failures = simulate_many(specs, workers, desc=f"our hand on {engine}")
    for reason in failures:
        print(f"  not simulated: {reason}")
    return made


def change_over_spread(reference: np.ndarray, other: np.ndarray) -> np.ndarray:
    """Per feature: mean |other - reference| over matched rows / std of reference's rows
    (features that do not vary across objects left out: nan)."""
    spread = reference.std(axis=0)
    change = np.abs(other - reference).mean(axis=0)
    return np.where(spread > 1e-12, change / np.where(spread > 1e-12, spread, 1.0), np.nan)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="a simulated set made by one hand")
    ap.add_argument("--other", help="a second set of the same objects (default: our hand)")
    ap.add_argument("--engine", default="mujoco", help="our hand's engine, without --other")
    ap.add_argument("--servo-stiffness", type=float, default=0.0,
                    help="our hand's finger servos (N m/rad; mujoco; 0: the model's own)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--descriptors", default=",".join(DESCRIPTORS))
    args = ap.parse_args()
    provenance()
    theirs = [r for r in records_from(args.data) if "no_contact" not in r.flags]
    mine = records_from(args.other) if args.other else ours(
        theirs, args.engine, args.workers, args.servo_stiffness
    )
    by_key = {(r.shape, r.seed): r for r in mine if "no_contact" not in r.flags}
    pairs = [(by_key[(r.shape, r.seed)], r) for r in theirs if (r.shape, r.seed) in by_key]
    if not pairs:
        raise SystemExit("no object is in both sets (matched by shape and seed)")
    reference = args.other or f"our hand on {args.engine}" + (
        f", servo stiffness {args.servo_stiffness:g}" if args.servo_stiffness else ""
    )
    print(f"{len(pairs)} objects grasped by both hands ({args.data} against {reference}); "
          "feature change / spread across objects, median over each descriptor's features:")
    for name in args.descriptors.split(","):
        d = get_descriptor(name)
        a = np.asarray(d.transform([p[0] for p in pairs]), dtype=float)
        b = np.asarray(d.transform([p[1] for p in pairs]), dtype=float)
        ratio = change_over_spread(a, b)
        print(f"  {name:<24}{np.nanmedian(ratio):6.2f}   (features: {np.sum(np.isfinite(ratio))}, "
              f"worst {np.nanmax(ratio):.2f})")


if __name__ == "__main__":
    main()
