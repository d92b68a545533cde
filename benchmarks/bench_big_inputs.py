"""Benchmark: peak memory and wall time of the big-input probes of issue 20.

- ``import`` of a CSV recording of --rows rows (time, 24 joints, 24 efforts, a grasp marker:
  a 1 s closing motion and a 0.4 s pause repeated at 100 Hz; 1,000,000 rows is ~440 MB);
- ``grasp --mesh`` of a binary STL icosphere of --subdivisions (8: 1.3M triangles, processed;
  9: 5.2M, over the 2M input limit, refused before parsing), with an empty mesh cache.

Each runs as its own process; the figures are that process's peak RSS (``ru_maxrss`` from
``wait4``) and wall time. Run it alone: it writes its inputs in a temporary folder.

    python benchmarks/bench_big_inputs.py [--rows 1000000] [--subdivisions 8 9]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy


def write_csv(path: Path, rows: int) -> None:
    from tactile_bullet.hand import JOINT_NAMES

    names = ["rh_" + n for n in JOINT_NAMES]
    header = ["time", *names, *[n + "_effort" for n in names], "grasp"]
    ramp = np.minimum(np.arange(140) / 100.0, 1.0)  # 1 s closing, then held 0.4 s
    with open(path, "w") as fh:
        fh.write(",".join(header) + "\n")
        done, grasp = 0, 0
        while done < rows:
            block = np.zeros((180, len(header)))
            block[:, 0] = (done + np.arange(180)) / 100.0
            block[:140, 1:25] = ramp[:, None] * 0.9
            block[:140, 25:49] = ramp[:, None] * 0.2
            block[:140, 49] = grasp + 1
            block = block[: rows - done]
            np.savetxt(fh, block, fmt=["%.2f"] + ["%.6f"] * 48 + ["%d"], delimiter=",")
            done, grasp = done + len(block), grasp + 1


def measure(argv: list[str], env: dict) -> tuple[float, float, str]:
    """(peak RSS in MB, wall s, last line of output) of one CLI run in a child process."""
    start = time.perf_counter()
    with tempfile.TemporaryFile("w+") as log:
        proc = subprocess.Popen([sys.executable, "-m", "tactile_bullet.cli", *argv], env=env,
                                stdout=log, stderr=subprocess.STDOUT)  # fmt: skip
        _, _, usage = os.wait4(proc.pid, 0)  # this child's own peak, not the largest so far
        proc.returncode = 0
        wall = time.perf_counter() - start
        log.seek(0)
        out = log.read().strip().splitlines()
    return usage.ru_maxrss / 1024, wall, out[-1][:160] if out else ""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--subdivisions", type=int, nargs="*", default=[8, 9])
    args = parser.parse_args()
    provenance()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        env = {**os.environ, "TACTILE_BULLET_CACHE": str(tmp / "cache")}
        if args.rows:
            csv = tmp / "big.csv"
            write_csv(csv, args.rows)
            mb = csv.stat().st_size / 2**20
            peak, wall, last = measure(["import", str(csv), "--out", str(tmp / "ds")], env)
            print(f"import {args.rows:,}-row CSV ({mb:.0f} MiB): peak RSS {peak:.0f} MiB "
                  f"({peak / mb:.2f}x the file), {wall:.1f} s: {last}")  # fmt: skip
            csv.unlink()
        for sub in args.subdivisions:
            import trimesh

            stl = tmp / f"ball{sub}.stl"
            trimesh.creation.icosphere(sub, radius=0.04).export(stl)
            peak, wall, last = measure(["grasp", "--mesh", str(stl)], env)
            tri = 20 * 4**sub
            print(f"grasp --mesh {tri:,}-triangle STL: peak RSS {peak:.0f} MiB, {wall:.1f} s: "
                  f"{last}")  # fmt: skip


if __name__ == "__main__":
    main()
