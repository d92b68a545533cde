"""Offline vs sequential neural forests: the `tactile-bullet sequential` command as a tool.

python benchmarks/sequential_experiment.py --data DIR --out figures/
python benchmarks/sequential_experiment.py --synthetic --timing
"""

import sys

from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.cli import main

if __name__ == "__main__":
    provenance()
    sys.exit(main(["sequential", *sys.argv[1:]]))
