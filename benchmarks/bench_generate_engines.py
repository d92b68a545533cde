"""generate's own cost per grasp on each engine: the same sweep simulated bare in this process,
by ``generate --workers 1`` and by ``generate --workers 0``, MuJoCo then Bullet (issue 30).

Prints, per engine, the first grasp's time, the bare time per grasp, both generate times and
the overhead of one worker; then MuJoCo / Bullet grasps per second in ``generate --workers 1``.
In this process MuJoCo's models are compiled, never read from the disk cache
(``mujoco_cache.ENABLED`` off). Then the command as a user runs it: ``tactile-bullet generate
--config SWEEP.toml --engine E --workers 1`` in a fresh process per engine (nothing imported or
compiled before it), timed whole and by its own ``wall_time_s``, and the same ratio: first with
an empty cache folder (``$TACTILE_BULLET_CACHE``: every mesh made and every MuJoCo model
compiled), then again with that folder as the first run left it (MuJoCo's compiled models read
back, ``sim/engines/mujoco_cache.py``). In this process the bare grasps have already compiled
each size's model, which a forked worker inherits: the fresh-process figures are the ones a
user sees.

    python benchmarks/bench_generate_engines.py [GRASPS, default 26]
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _report import provenance  # first: this checkout ahead of an installed copy
from bench_generate import sweep

from tactile_bullet.datasets.executors import run_task
from tactile_bullet.datasets.generate import generate
from tactile_bullet.datasets.sweep_engines import with_engine
from tactile_bullet.sim.engines import mujoco_cache


def main() -> None:
    provenance()
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 26
    work = Path(tempfile.mkdtemp())
    mujoco_cache.ENABLED = False  # in this process: compiled, as before the disk cache
    took = {}
    try:
        for engine in ("mujoco", "bullet"):
            s = with_engine(sweep(n), engine)
            tasks = s.tasks(0)
            start = time.perf_counter()
            run_task(tasks[0])
            first = time.perf_counter() - start
            start = time.perf_counter()
            for task in tasks:
                run_task(task)
            bare = time.perf_counter() - start
            one = generate(s, work / f"{engine}1", workers=1)["wall_time_s"]
            none = generate(s, work / f"{engine}0", workers=0)["wall_time_s"]
            took[engine] = one
            print(f"{engine}: first grasp {first:.2f} s; bare {bare:.2f} s "
                  f"({1e3 * bare / len(tasks):.0f} ms a grasp); generate --workers 1 {one:.2f} s, "
                  f"--workers 0 {none:.2f} s; one worker adds {one / bare - 1:+.0%}")  # fmt: skip
        print(f"MuJoCo / Bullet grasps per second, generate --workers 1: "
              f"{took['bullet'] / took['mujoco']:.2f}x")  # fmt: skip
        config = work / "sweep.toml"
        config.write_text(toml_of(n))
        for cache in ("cold", "warm"):  # an empty cache folder, then as the cold run left it
            fresh = {}
            for engine in ("mujoco", "bullet"):
                out = work / f"{engine}-cli-{cache}"
                env = {**os.environ, "TACTILE_BULLET_CACHE": str(work / f"cache-{engine}")}
                start = time.perf_counter()
                done = subprocess.run(
                    [sys.executable, "-m", "tactile_bullet.cli", "generate", "--config",
                     str(config), "--engine", engine, "--workers", "1", "--out", str(out),
                     "--json"],
                    check=True, capture_output=True, text=True, env=env,
                )  # fmt: skip
                whole = time.perf_counter() - start
                inner = json.loads(done.stdout)["wall_time_s"]
                fresh[engine] = (whole, inner)
                print(f"{engine}: tactile-bullet generate --workers 1 in a fresh process, "
                      f"{cache} cache: {whole:.2f} s whole, {inner:.2f} s by its wall_time_s")
            print(f"MuJoCo / Bullet grasps per second, fresh generate --workers 1, {cache} "
                  f"cache: {fresh['bullet'][0] / fresh['mujoco'][0]:.2f}x whole command, "
                  f"{fresh['bullet'][1] / fresh['mujoco'][1]:.2f}x by wall_time_s")  # fmt: skip
    finally:
        shutil.rmtree(work, ignore_errors=True)


def toml_of(n: int) -> str:
    """The sweep of :func:`bench_generate.sweep` as a config file."""
    s = sweep(n)
    lines = [f'name = "{s.name}"']
    for shape in s.shapes:
        lines += ["[[shapes]]", f'name = "{shape.name}"']
        params = ", ".join(f"{k} = {list(v)}" for k, v in shape.params.items())
        lines.append(f"params = {{ {params} }}")
        lines.append(f"offset_x = {list(shape.offset_x)}")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
