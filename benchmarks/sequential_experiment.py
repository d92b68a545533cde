"""Offline vs sequential neural forests: the `tactile-bullet sequential` command as a tool.

python tools/sequential_experiment.py --data DIR --out figures/
python tools/sequential_experiment.py --synthetic --timing
"""

import sys

from tactile_bullet.cli import main

if __name__ == "__main__":
    sys.exit(main(["sequential", *sys.argv[1:]]))
