"""Where a grasp's CPU time goes: the engine's stepping against everything else (the
controller's Python, reads and writes of the engine's state, scene build, record).

Each engine's ``step`` is wrapped with a CPU-time counter for the run; the shapes are grasped
once to warm the caches (compiled models), then ``--repeat`` times.

    python benchmarks/profile_grasp.py --engine mujoco --mode torque
    python benchmarks/profile_grasp.py --engine bullet,mujoco --mode contact --repeat 5
    python benchmarks/profile_grasp.py --engine mujoco --mujoco-timers

``--mujoco-timers`` then grasps each shape once more on MuJoCo and prints where its own
stepping went, by MuJoCo's internal timers (``mjData.timer``): the narrow-phase collision
tests against the object's convex pieces, the constraint solver and the rest.
"""

from __future__ import annotations

import argparse
import time

from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.objects.shapes import BUILTIN_SHAPES
from tactile_bullet.records import ControllerSettings
from tactile_bullet.sim.grasp import simulate_grasp

THESIS_SHAPES = "cone,torus,sphere,hyperboloid,cylinder"


def engine_class(name: str) -> type:
    if name == "mujoco":
        from tactile_bullet.sim.engines.mujoco import MujocoEngine

        return MujocoEngine
    from tactile_bullet.sim.engines.bullet import BulletEngine

    return BulletEngine


def split(engine: str, mode: str, shapes: list, repeat: int) -> tuple[float, float, float]:
    """(CPU ms per grasp, of which in the engine's step, controller ticks per grasp)."""
    cls = engine_class(engine)
    inner = cls.step
    spent = [0.0]

    def timed_step(self) -> None:
        start = time.thread_time()
        inner(self)
        spent[0] += time.thread_time() - start

    ctl = ControllerSettings(mode=mode, engine=engine)
    for shape in shapes:
        simulate_grasp(shape, controller=ctl)
    cls.step = timed_step
    try:
        steps, start = 0, time.thread_time()
        for _ in range(repeat):
            for shape in shapes:
                steps += simulate_grasp(shape, controller=ctl).steps
        total = time.thread_time() - start
    finally:
        cls.step = inner
    n = repeat * len(shapes)
    return total / n * 1e3, spent[0] / n * 1e3, steps / n


def mujoco_timers(shapes: list, mode: str) -> None:
    """One grasp of each shape on MuJoCo (its model compiled already), and MuJoCo's own
    timers of that grasp's stepping, in ms."""
    import mujoco

    from tactile_bullet.sim.engines.mujoco import OBJECT_BODY, MujocoEngine

    inner, seen = MujocoEngine.step, []

    def keep(self) -> None:
        inner(self)
        if not seen or seen[-1][0] is not self.data:
            seen.append((self.data, self.model))

    ctl = ControllerSettings(mode=mode, engine="mujoco")
    parts = {"step": mujoco.mjtTimer.mjTIMER_STEP,
             "collision (narrow phase)": mujoco.mjtTimer.mjTIMER_COL_NARROW,
             "collision (broad phase)": mujoco.mjtTimer.mjTIMER_COL_BROAD,
             "constraint solver": mujoco.mjtTimer.mjTIMER_CONSTRAINT}  # fmt: skip
    for shape in shapes:
        simulate_grasp(shape, controller=ctl)  # compiled, warm
        MujocoEngine.step = keep
        try:
            seen.clear()
            steps = simulate_grasp(shape, controller=ctl).steps
        finally:
            MujocoEngine.step = inner
        data, model = seen[-1]
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, OBJECT_BODY)
        pieces = int((model.geom_bodyid == body).sum())
        ms = {k: data.timer[int(t)].duration * 1e3 for k, t in parts.items()}
        print(f"mujoco timers, {shape.name} ({pieces} object geoms, {steps} ticks): "
              + ", ".join(f"{k} {v:.1f} ms" for k, v in ms.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--engine", default="mujoco", help="engines, comma-separated")
    parser.add_argument("--mode", default="torque", choices=("torque", "contact"))
    parser.add_argument("--shapes", default=THESIS_SHAPES)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--mujoco-timers", action="store_true",
                        help="also MuJoCo's own timers of one grasp per shape")
    args = parser.parse_args()
    provenance()
    table = {s.name: s for s in BUILTIN_SHAPES}
    shapes = [table[name] for name in args.shapes.split(",")]
    for engine in args.engine.split(","):
        total, stepping, ticks = split(engine, args.mode, shapes, args.repeat)
        rest = total - stepping
        print(f"{engine} {args.mode}: {total:.1f} ms CPU per grasp, {stepping:.1f} in step "
              f"({stepping / total:.0%}), {rest:.1f} elsewhere ({rest / total:.0%}); "
              f"{ticks:.0f} ticks, {rest / ticks * 1e3:.1f} us of the rest per tick")
    if args.mujoco_timers:
        mujoco_timers(shapes, args.mode)


if __name__ == "__main__":
    main()
