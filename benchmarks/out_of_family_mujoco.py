"""Objects of no family in our MuJoCo hand: how often the shipped default answers unknown.

The robustness matrix grasps its two out-of-family sets in Bullet only, while issue 27 asks
for the unknown share on every hand. This grasps the same objects at the same poses (each
set's own table and seed, from the matrix's ``objects`` folder) with our MJCF hand in MuJoCo,
caches them beside the matrix's sets (``robust-out-of-family-mujoco-rK``, ...), and prints,
per set and engine, the share the shipped default (or ``--model``) answers unknown, by rule,
and object by object (as ``unknown_by_rule.py`` prints the Bullet sets).

MuJoCo collides each concave mesh as the convex hulls of its cells (``sim/engines/
mujoco_objects.py``): the hulls' flat faces tilt the contact normals, which the axis rule
reads, so a MuJoCo set says what a hand grasping such pieces would get, not a smooth object.

    python benchmarks/out_of_family_mujoco.py --cache OUT/data --replicate 18 [--workers 2]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from _report import matrix_set, provenance  # first: this checkout ahead of an installed copy
from unknown_by_rule import by_object

from tactile_bullet.experiments.benchmark import load_set, simulate_sets
from tactile_bullet.experiments.robustness_sets import (
    OUT_OF_FAMILY_SETS,
    plugin_shapes,
    set_specs,
)
from tactile_bullet.learn.default import resolve_model


def mujoco_twin(spec):
    """The sweep set ``spec`` (an out-of-family set) grasped by our hand in MuJoCo: the same
    table, objects and seed, its cache folder named ``-mujoco``."""
    table = dict(spec.table) | {"engine": "mujoco", "name": f"{spec.table['name']}-mujoco"}
    return dataclasses.replace(spec, name=f"{spec.name}-mujoco", table=table)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cache", required=True, help="a robustness matrix's data folder")
    ap.add_argument("--replicate", type=int, default=0, help="the run's --replicate")
    ap.add_argument("--model", default=None, help="a model file (default: the shipped one)")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    provenance(argv)
    cache = Path(args.cache)
    specs = set_specs("full", {}, cache / "objects", plugin_shapes(), args.replicate)
    twins = [mujoco_twin(specs[name]) for name in OUT_OF_FAMILY_SETS]
    simulate_sets(twins, cache, args.workers, True, print)
    model = resolve_model(args.model)
    for name, twin in zip(OUT_OF_FAMILY_SETS, twins, strict=True):
        for engine, records in (("bullet", matrix_set(cache, name, args.replicate)),
                                ("mujoco", load_set(cache / twin.name)[0])):  # fmt: skip
            by_object(f"{name} ({engine})", model, records)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
