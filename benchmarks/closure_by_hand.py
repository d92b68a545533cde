"""How far each hand closes, and how much of it tells a hyperboloid's waist from a cylinder.

Reads a robustness matrix's cached sets and prints, per set (our randomised hands, our held-out
grasps, the hands written by others): the waist signal, the mean closure (J3 + J2 + J1) of the
middle and ring fingers minus that of the index and little fingers, on hyperboloids and on
cylinders, how many spreads apart the two are, and the total closure of the four long fingers
on hyperboloids (docs/robustness.md, root causes).

Usage: python benchmarks/closure_by_hand.py --cache OUT/data [--scale full]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments import robustness as R
from tactile_bullet.experiments.benchmark import load_set

SETS = ("bullet-train-randomized", "mujoco-train-randomized", "test", "menagerie", "gymnasium")


def waist(records, shape: str) -> np.ndarray:
    """Middle and ring fingers' closure minus index and little fingers' (deg), per grasp."""
    out = [r.fci_angles().sum(axis=0) for r in records if r.shape == shape]
    return np.degrees([(t[1] + t[2]) / 2 - (t[0] + t[3]) / 2 for t in out])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", required=True)
    ap.add_argument("--scale", default="full")
    args = ap.parse_args()
    provenance()
    specs = R.set_specs(args.scale, {h: "given" for h in R.OTHER_HANDS}, None)
    for name in SETS:
        path = Path(args.cache) / specs[name].name
        if not path.exists():
            print(f"{name}: not in the cache")
            continue
        recs = load_set(path)[0]
        h, c = waist(recs, "hyperboloid"), waist(recs, "cylinder")
        sep = (h.mean() - c.mean()) / np.sqrt((h.var() + c.var()) / 2)
        total = np.mean([np.degrees(r.fci_angles().sum()) for r in recs
                         if r.shape == "hyperboloid"])  # fmt: skip
        print(f"{name:25s} waist signal: hyperboloid {h.mean():5.1f} +- {h.std():4.1f} deg, "
              f"cylinder {c.mean():5.1f} +- {c.std():4.1f} deg ({sep:.2f} spreads apart); "
              f"total closure on hyperboloids {total:.0f} deg")


if __name__ == "__main__":
    main()
