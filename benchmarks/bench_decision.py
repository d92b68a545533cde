"""How long choosing the next grasp takes (issue 28: at most 2 s on 2 cores on MuJoCo): one
``exploration.plan`` decision after a first grasp of each of issue 28's border objects and two
turned ones, every hypothesis grasp simulated afresh (an empty cache), with the decision's
grasps simulated on every core and, in the same run, one after another.

Prints each decision's seconds both ways, the new grasps it simulated, and the medians and the
ratio; the answers (the pose chosen) are the same both ways.

    python benchmarks/bench_decision.py [--repeat 2]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments import exploration as E
from tactile_bullet.learn.default import default_model
from tactile_bullet.records import ControllerSettings, Pose
from tactile_bullet.sim.grasp import simulate_grasp

OBJECTS = (
    ("torus", {"major_radius": 0.056, "minor_radius": 0.052}, Pose()),
    ("hyperboloid", {"waist_radius": 0.036, "end_radius": 0.042}, Pose((0.002, 0.0, 0.0))),
    ("cylinder", {"radius": 0.05, "length": 0.11}, Pose(rotation=math.radians(20.0))),
    ("cone", {}, Pose((0.01, 0.0, 0.0), math.radians(-15.0))),
    ("sphere", {}, Pose((-0.01, 0.0, 0.0))),
)
"""Issue 28's border objects (a torus whose tube nearly closes its hole, a hyperboloid with a
slight waist, a short wide cylinder turned 20 deg) and two of its unseen poses."""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=2, help="decisions per object and way")
    args = ap.parse_args(argv)
    provenance(argv)
    ctl = ControllerSettings(engine="mujoco")
    model = default_model()
    first = [(shape, E.Grasp(simulate_grasp(shape, params, pose, ctl), pose))
             for shape, params, pose in OBJECTS]  # fmt: skip
    E.plan([first[0][1]], model, ctl, cache=E.SimulationCache())  # compile and load once
    took: dict[str, list[float]] = {"every core": [], "one by one": []}
    ways = (("every core", E.PARALLEL_SIMULATIONS), ("one by one", 10**9))
    print(f"{'object':12s} {'every core s':>12s} {'one by one s':>12s} {'grasps':>6s}  pose")
    for shape, grasp in first:
        row = {}
        for way, least in ways:
            E.PARALLEL_SIMULATIONS = least
            times = []
            for _ in range(args.repeat):
                start = time.perf_counter()
                decision = E.plan([grasp], model, ctl, cache=E.SimulationCache())
                times.append(time.perf_counter() - start)
            took[way] += times
            row[way] = (min(times), decision)
        E.PARALLEL_SIMULATIONS = ways[0][1]
        (fast, d1), (slow, d2) = row["every core"], row["one by one"]
        assert d1["pose"] == d2["pose"], shape
        print(f"{shape:12s} {fast:12.2f} {slow:12.2f} {d1['simulated']:6d}  move {d1['move']}")
    a, b = (statistics.median(took[w]) for w in ("every core", "one by one"))
    print(f"median decision: every core {a:.2f} s, one by one {b:.2f} s ({b / a:.2f}x); "
          f"slowest {max(took['every core']):.2f} s and {max(took['one by one']):.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
