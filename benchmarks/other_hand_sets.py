"""Grasp sets made by "other hands", for ``benchmarks/hand_calibration.py`` (issue 21 item 3).

Each set holds ``--per-shape`` grasps of each of the five thesis shapes at sizes drawn from
fractions 0.1-0.9 of their ranges and at the demo's train and test offsets, made by one hand
that is not the one the shape fit's shipped coefficients were fitted on:

- ``mujoco``: the MuJoCo engine's hand (a physical J1/J2 tendon, distal phalanx first);
- ``shifted-distal``: Bullet with every physics knob +20% (friction, thresT, closing speed;
  phalanges +2%), the distal-first tendon rule, sensors reading J3 +3 deg and J2 -1 deg;
- ``shifted-equal``: Bullet at -20%, the equal-torque tendon rule, J3 -2 deg and J2 -1 deg;
- ``independent``: the MuJoCo engine driving the hand model named by ``--hand-model`` (the
  Menagerie's independently written Shadow hand, ``tactile-bullet convert-hand``), default
  physics otherwise.

Usage: python benchmarks/other_hand_sets.py --hand mujoco --out DIR [--per-shape 24] [--workers 2]
       python benchmarks/other_hand_sets.py --hand independent --hand-model HAND.xml --out DIR
(about a minute per 120 grasps on two free cores).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.datasets.bulk import save_records, simulate_many
from tactile_bullet.experiments.protocols import shifted
from tactile_bullet.experiments.workflow import (
    DEMO_SHAPES,
    TEST_OFFSETS,
    TRAIN_OFFSETS,
    draw_specs,
)
from tactile_bullet.records import ControllerSettings

FRACTIONS = (0.1, 0.3, 0.5, 0.7, 0.9)


def _offsets(j3_deg: float) -> tuple[float, ...]:
    return tuple(v for _ in range(4) for v in (math.radians(j3_deg), math.radians(-1.0), 0.0))


HANDS = {
    "mujoco": (31, ControllerSettings(engine="mujoco")),
    "shifted-distal": (23, replace(shifted(ControllerSettings(), 0.2), coupling="distal-first",
                                   joint_offsets=_offsets(3.0))),
    "shifted-equal": (29, replace(shifted(ControllerSettings(), -0.2), coupling="equal-torque",
                                  joint_offsets=_offsets(-2.0))),
    "independent": (41, ControllerSettings(engine="mujoco")),
}  # fmt: skip
"""hand name -> (seed of the size and offset draws, controller)."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hand", required=True, choices=sorted(HANDS))
    ap.add_argument("--out", required=True)
    ap.add_argument("--per-shape", type=int, default=24)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--hand-model", help="the MJCF hand of --hand independent")
    args = ap.parse_args()
    provenance()
    seed, ctl = HANDS[args.hand]
    if (args.hand == "independent") != bool(args.hand_model):
        sys.exit("--hand-model goes with --hand independent, and it needs one")
    if args.hand_model:
        from tactile_bullet.sim.engines.mujoco_hand import load_hand_spec

        load_hand_spec(args.hand_model)  # a bad file stops here, before any grasp
        ctl = replace(ctl, hand_model=str(Path(args.hand_model).resolve()))
    out = Path(args.out)
    if out.exists() and any(out.iterdir()):
        sys.exit(f"{out} is not empty: name a new folder")
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    specs = [s for name in DEMO_SHAPES
             for s in draw_specs(name, args.per_shape, FRACTIONS, TEST_OFFSETS + TRAIN_OFFSETS,
                                 rng, controller=ctl)]  # fmt: skip
    records, failures = simulate_many(specs, args.workers, desc=f"{args.hand} grasps")
    save_records(records, out)
    print(f"{len(records)} of {len(specs)} grasps written to {out}")
    for reason in failures:
        print(f"  not simulated: {reason}")


if __name__ == "__main__":
    main()
