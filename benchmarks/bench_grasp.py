"""Benchmark: grasps per second per core, against each engine's own ceiling.

For each engine, shape and controller mode, on one core (this process):
- grasps/s: full simulate_grasp calls (scene build, Algorithm 1, record), best of --repeat;
- cpu g/s: the same grasps timed by this thread's CPU time (best of --repeat): what one core
  delivers, much less exposed than wall time to other processes sharing the machine (their
  load still slows it through shared caches, so compare engines side by side);
- cold g/s: the same with every per-process cache of compiled models emptied first (mujoco
  compiles each object size once, ~1-40 ms; a dataset of many sizes pays it often);
- steps/grasp: physics steps Algorithm 1 needed;
- ceiling: the engine's bare tick rate with the hand holding that object (its stepping in a
  loop, no Python work between ticks) divided by steps/grasp: the most any controller written
  around these steps could reach;
- ratio = grasps/s / ceiling;
- peak RSS of this process.

    python benchmarks/bench_grasp.py [--repeat 3] [--shapes cone,sphere] [--modes torque]
    python benchmarks/bench_grasp.py --preshape   # fingers start 5 mm from the object (opt-in)
    python benchmarks/bench_grasp.py --engine bullet,mujoco   # side by side, with the speed-up
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.objects.shapes import BUILTIN_SHAPES
from tactile_bullet.records import ControllerSettings
from tactile_bullet.sim.grasp import simulate_grasp

CEILING_STEPS = 240


def bare_step_rate(engine) -> float:
    """Controller ticks/s of the engine alone with the hand closed on the object."""
    return engine.bare_step_rate(CEILING_STEPS)


def forget_compiled(engine: str) -> None:
    if engine == "mujoco":
        from tactile_bullet.sim.engines.mujoco import clear_compiled

        clear_compiled()


def bench(shape, mode: str, repeat: int, preshape: bool = False, engine: str = "bullet") -> dict:
    ctl = ControllerSettings(mode=mode, preshape=preshape, engine=engine)
    walls, cpus, colds, rates = [], [], [], []
    record = None
    for _ in range(repeat):
        start, cpu = time.perf_counter(), time.thread_time()
        record = simulate_grasp(shape, controller=ctl)
        walls.append(time.perf_counter() - start)
        cpus.append(time.thread_time() - cpu)
        forget_compiled(engine)
        start = time.perf_counter()
        simulate_grasp(shape, controller=ctl)
        colds.append(time.perf_counter() - start)
    simulate_grasp(shape, controller=ctl, scene_hook=lambda s: rates.append(bare_step_rate(s)))
    gps = 1.0 / min(walls)
    ceiling = rates[0] / record.steps
    return {
        "engine": engine,
        "shape": shape.name,
        "mode": mode,
        "grasps_per_s": gps,
        "cpu_grasps_per_s": 1.0 / min(cpus),
        "cold_grasps_per_s": 1.0 / min(colds),
        "steps": record.steps,
        "bare_steps_per_s": rates[0],
        "ceiling_grasps_per_s": ceiling,
        "ratio": gps / ceiling,
        "fingers": "".join(f[0] for f in record.fingers_in_contact),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--shapes", default=",".join(s.name for s in BUILTIN_SHAPES))
    parser.add_argument("--modes", default="torque,contact")
    parser.add_argument("--engine", default="bullet", help="engines, comma-separated")
    parser.add_argument(
        "--preshape", action="store_true",
        help="start the fingers 5 mm from the object (ControllerSettings.preshape)",
    )  # fmt: skip
    args = parser.parse_args()
    provenance()
    table = {s.name: s for s in BUILTIN_SHAPES}
    engines = args.engine.split(",")
    rows = []
    print(f"{'engine':<8}{'shape':<18}{'mode':<8}{'grasps/s':>9}{'cpu g/s':>9}{'cold g/s':>9}"
          f"{'steps':>7}"
          f"{'bare st/s':>10}"
          f"{'ceiling':>9}{'ratio':>7}  fingers")  # fmt: skip
    for name in args.shapes.split(","):
        for mode in args.modes.split(","):
            for engine in engines:  # side by side: the machine's load hits both alike
                row = bench(table[name], mode, args.repeat, args.preshape, engine)
                rows.append(row)
                print(f"{engine:<8}{row['shape']:<18}{row['mode']:<8}"
                      f"{row['grasps_per_s']:>9.2f}{row['cpu_grasps_per_s']:>9.2f}"
                      f"{row['cold_grasps_per_s']:>9.2f}{row['steps']:>7}"
                      f"{row['bare_steps_per_s']:>10.0f}{row['ceiling_grasps_per_s']:>9.2f}"
                      f"{row['ratio']:>7.2f}  {row['fingers']}", flush=True)  # fmt: skip
    for mode in args.modes.split(","):
        means, colds, cpus = {}, {}, {}
        for engine in engines:
            sel = [r for r in rows if r["mode"] == mode and r["engine"] == engine]
            means[engine] = gps = np.mean([r["grasps_per_s"] for r in sel])
            cold = np.mean([r["cold_grasps_per_s"] for r in sel])
            colds[engine] = cold
            cpus[engine] = cpu = np.mean([r["cpu_grasps_per_s"] for r in sel])
            ratio = np.mean([r["ratio"] for r in sel])
            steps = np.mean([r["steps"] for r in sel])
            bare = np.mean([r["bare_steps_per_s"] for r in sel])
            print(f"mean {engine} {mode}: {gps:.2f} grasps/s per core ({cpu:.2f} by CPU time, "
                  f"{cold:.2f} cold), "
                  f"{steps:.0f} steps/grasp, "
                  f"{bare:.0f} bare ticks/s closed, {ratio:.2f} of the ceiling")  # fmt: skip
        for engine in engines[1:]:
            # per shape, the two engines ran one after the other: their ratio is the least
            # exposed to the machine's changing load; the median of those is the figure
            pairs = [(a, b) for a in rows for b in rows
                     if a["mode"] == b["mode"] == mode and a["shape"] == b["shape"]
                     and a["engine"] == engines[0] and b["engine"] == engine]  # fmt: skip
            warm = np.median([b["grasps_per_s"] / a["grasps_per_s"] for a, b in pairs])
            cold = np.median([b["cold_grasps_per_s"] / a["cold_grasps_per_s"] for a, b in pairs])
            cpu = np.median([b["cpu_grasps_per_s"] / a["cpu_grasps_per_s"] for a, b in pairs])
            print(f"{engine} / {engines[0]} {mode}: {means[engine] / means[engines[0]]:.1f}x "
                  f"grasps/s per core ({colds[engine] / colds[engines[0]]:.1f}x cold); median "
                  f"of the per-shape ratios {warm:.1f}x ({cold:.1f}x cold, {cpu:.1f}x by CPU "
                  f"time)")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory of this simulation process: {peak:.0f} MiB")


if __name__ == "__main__":
    main()
