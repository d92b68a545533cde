"""generate's own cost per grasp on each engine: the same sweep simulated bare in this process,
by ``generate --workers 1`` and by ``generate --workers 0``, MuJoCo then Bullet (issue 30).

Prints, per engine, the first grasp's time, the bare time per grasp, both generate times and
the overhead of one worker; then MuJoCo / Bullet grasps per second in ``generate --workers 1``.

    python benchmarks/bench_generate_engines.py [GRASPS, default 26]
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

from _report import provenance  # first: this checkout ahead of an installed copy
from bench_generate import sweep

from tactile_bullet.datasets.executors import run_task
from tactile_bullet.datasets.generate import generate
from tactile_bullet.datasets.sweep_engines import with_engine


def main() -> None:
    provenance()
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 26
    work = Path(tempfile.mkdtemp())
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
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
