"""MuJoCo's compiled models across processes (``sim/engines/mujoco_cache.py``): per built-in
thesis shape at its default size, the time to compile the hand with the object, to write the
cache entry, and to read it back, medians over repeats in this process (a temporary cache
folder; the in-process models forgotten before each compile).

    python benchmarks/bench_mujoco_cache.py [REPEATS, default 7]
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile

from _report import provenance, timings  # first: this checkout ahead of an installed copy

from tactile_bullet.objects.shapes import BUILTIN_SHAPES, THESIS_SHAPES
from tactile_bullet.records import ControllerSettings
from tactile_bullet.sim.engines import mujoco as M
from tactile_bullet.sim.engines import mujoco_cache as C
from tactile_bullet.sim.engines.mujoco_objects import object_geoms


def _median_ms(fn, repeats: int) -> float:
    return 1e3 * statistics.median(timings(fn, repeats))


def main(argv: list[str]) -> int:
    provenance()
    repeats = int(argv[0]) if argv else 7
    os.environ["TACTILE_BULLET_CACHE"] = tempfile.mkdtemp()
    ctl = ControllerSettings(engine="mujoco")
    table = {s.name: s for s in BUILTIN_SHAPES}
    M._prototype(table["sphere"], table["sphere"].resolve({}), ctl, None)  # imports, the MJCF
    for name in THESIS_SHAPES:
        shape = table[name]
        params = shape.resolve({})
        geoms = object_geoms(shape, params)
        key = C.model_key(geoms, ctl.timestep / M.SUBSTEPS, 1.0)
        path = C.entry_path(key)

        def compile_once(shape=shape, params=params):
            C.ENABLED = False
            M.clear_compiled()
            M._prototype(shape, params, ctl, None)
            C.ENABLED = True

        compiled = _median_ms(compile_once, repeats)
        model = M._prototype(shape, params, ctl, None).model
        written = _median_ms(lambda: C._write(path, key, model), repeats)  # noqa: B023
        read = _median_ms(lambda: C._read(path, key), repeats)  # noqa: B023
        print(f"{name:12s} compile {compiled:6.1f} ms, write {written:5.1f} ms, read back "
              f"{read:5.2f} ms, entry {path.stat().st_size / 1e3:.0f} kB", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
