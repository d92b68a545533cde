"""Time the README's tour as a newcomer runs it: every ```bash block of its "A short tour"
section, in order, in a fresh empty folder, each block as one ``bash -e`` script, with each
command's own wall time (bash's xtrace stamps) and the total.

    python benchmarks/tour_time.py [--keep DIR]

The blocks run exactly as the README has them (``tactile-bullet`` bound to this interpreter,
installed console script or not); a failing command stops the run and fails the script.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _report import provenance  # first: this checkout ahead of an installed copy

REPO = Path(__file__).resolve().parent.parent
PRELUDE = """\
set -euo pipefail
tactile-bullet() { "$TB_PYTHON" -m tactile_bullet.cli "$@"; }
export PS4='+@$EPOCHREALTIME '
set -x
"""


def tour_blocks(text: str) -> list[str]:
    """The bash blocks of the README's "A short tour" section, in order."""
    section = re.search(r"^## A short tour\n(.*?)(?=^## )", text, re.S | re.M).group(1)
    return re.findall(r"^```bash\n(.*?)^```", section, re.S | re.M)


def stamps(trace: str) -> list[tuple[float, str]]:
    """(start time, command) of each traced ``tactile-bullet`` call, from bash's xtrace."""
    out = []
    for line in trace.splitlines():
        m = re.match(r"^\++@(\d+\.\d+) (.*)$", line)
        if m and m.group(2).startswith(("tactile-bullet ", "cat ")):
            out.append((float(m.group(1)), m.group(2)))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--keep", type=Path, help="run in this (new, empty) folder and keep it")
    args = parser.parse_args()
    provenance()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="tour-"))
    folder.mkdir(parents=True, exist_ok=True)
    if any(folder.iterdir()):
        sys.exit(f"{folder} is not empty: the tour starts in an empty folder")
    env = {**os.environ, "TB_PYTHON": sys.executable, "MPLBACKEND": "Agg"}
    env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
    blocks = tour_blocks((REPO / "README.md").read_text())
    total = time.perf_counter()
    rows = []
    for number, code in enumerate(blocks):
        start = time.perf_counter()
        proc = subprocess.run(["bash", "-c", PRELUDE + code], cwd=folder, env=env,
                              capture_output=True, text=True)  # fmt: skip
        end = time.time()
        took = time.perf_counter() - start
        calls = stamps(proc.stderr)
        for i, (t0, cmd) in enumerate(calls):
            t1 = calls[i + 1][0] if i + 1 < len(calls) else end
            rows.append((t1 - t0, cmd))
            print(f"{t1 - t0:7.1f} s  {cmd}", flush=True)
        print(f"block {number}: {took:.1f} s", flush=True)
        if proc.returncode:
            print(proc.stderr[-3000:], file=sys.stderr)
            sys.exit(f"block {number} exited {proc.returncode}")
    took = time.perf_counter() - total
    print(f"the tour: {len(blocks)} blocks, {len(rows)} commands, {took:.0f} s "
          f"({took / 60:.1f} min) in {folder}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
