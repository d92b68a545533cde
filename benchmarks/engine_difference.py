"""How differently the two engines close the hand on the same objects: per-joint mean absolute
difference of the final angles, bullet vs mujoco, over the same grasps.

The grasps are the demo's test recipe (sizes between the training ones, offsets up to 5 mm),
drawn once with a fixed seed and simulated on each engine; a grasp refused or without contact
on either engine is left out of both.

    python benchmarks/engine_difference.py [--per-shape 20] [--mode torque] [--seed 0]
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.datasets.bulk import simulate_many
from tactile_bullet.experiments.workflow import (
    DEMO_SHAPES,
    TEST_FRACTIONS,
    TEST_OFFSETS,
    draw_specs,
)
from tactile_bullet.hand import FCI_JOINTS, JOINT_NAMES, LONG_FINGERS, THUMB_OPPOSED
from tactile_bullet.records import ControllerSettings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-shape", type=int, default=20)
    parser.add_argument("--mode", default="torque", choices=("torque", "contact"))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--engines", default="bullet,mujoco")
    args = parser.parse_args()
    provenance()
    a, b = args.engines.split(",")
    rng = np.random.default_rng(args.seed)
    specs = [s for shape in DEMO_SHAPES
             for s in draw_specs(shape, args.per_shape, TEST_FRACTIONS, TEST_OFFSETS, rng)]
    runs = {}
    for engine in (a, b):
        ctl = ControllerSettings(mode=args.mode, engine=engine)
        records, failures = simulate_many([replace(s, controller=ctl) for s in specs])
        runs[engine] = {(r.shape, r.seed): r for r in records if "no_contact" not in r.flags}
    keys = [k for k in runs[a] if k in runs[b]]
    joints = [j for f in LONG_FINGERS for j in FCI_JOINTS[f]] + list(THUMB_OPPOSED)
    cols = [JOINT_NAMES.index(j) for j in joints]
    diff = np.array([np.abs(runs[a][k].final_angles[cols] - runs[b][k].final_angles[cols])
                     for k in keys])  # fmt: skip
    print(f"{len(keys)} grasps on both engines ({len(specs)} drawn, {args.mode} mode): "
          f"mean |{a} - {b}| of the final angle, deg")
    for j, d in zip(joints, diff.T, strict=True):
        print(f"  {j:<6}{math.degrees(d.mean()):6.1f}")
    for row in ("J3", "J2", "J1"):
        sel = [i for i, j in enumerate(joints) if j.endswith(row) and not j.startswith("TH")]
        print(f"  long-finger {row}: {math.degrees(diff[:, sel].mean()):.1f} deg")
    flex = {e: np.mean([runs[e][k].fci_angles().sum(axis=0).mean() for k in keys]) for e in (a, b)}
    print(f"  mean total flexion J3+J2+J1 per finger: {a} {math.degrees(flex[a]):.0f} deg, "
          f"{b} {math.degrees(flex[b]):.0f} deg")


if __name__ == "__main__":
    main()
