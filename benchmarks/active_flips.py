"""Which objects of the ``active`` protocol a later grasp turns: each object of the columns
asked for explored with the planned next pose to three grasps (as ``benchmark --protocol
active`` explores it, the same objects and seeds), and every object whose fused answer changes
after its first grasp printed with each grasp's own answer, pose and the fused answers
(docs/performance.md, "Beyond one grasp": the planned third grasp).

    python benchmarks/active_flips.py [--scale full] [--seed 1] [--columns border,unseen-poses]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments.active import GRASPS, columns
from tactile_bullet.experiments.exploration import SimulationCache, explore
from tactile_bullet.learn.default import default_model


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", default="full", help="the protocol's scale (quick, full)")
    ap.add_argument("--seed", type=int, default=1, help="the protocol's --seed")
    ap.add_argument("--columns", default="border,unseen-poses", help="columns, comma-separated")
    args = ap.parse_args(argv)
    provenance(argv)
    model = default_model()
    with tempfile.TemporaryDirectory() as tmp:
        table = columns(args.scale, {}, args.seed, Path(tmp))
        for name in args.columns.split(","):
            controller, objects = table[name]
            lost = won = 0
            for i, (shape, params, first, *family) in enumerate(objects):
                truth = family[0] if family else shape
                doc = explore(shape, params, first, controller, max_grasps=GRASPS, model=model,
                              strategy="planned", seed=args.seed + i, cache=SimulationCache(),
                              until_settled=False)  # fmt: skip
                fused = [f["shape"] for f in doc["fused"]]
                if len(set(fused)) == 1:
                    continue
                lost += fused[-2] == truth != fused[-1]
                won += fused[-2] != truth == fused[-1]
                poses = [(round(1000 * g["pose"]["offset"][0], 1),
                          round(1000 * g["pose"]["offset"][2], 1),
                          round(g["pose"]["rotation_deg"], 1)) for g in doc["grasps"]]  # fmt: skip
                own = [g["answer"]["shape"] for g in doc["grasps"]]
                print(f"{name} #{i} {truth}: answers {own}, fused {fused}, poses (mm, mm, deg) "
                      f"{poses}")  # fmt: skip
            print(f"{name}: the last grasp turned {lost} right answers wrong and {won} wrong "
                  f"ones right, of {len(objects)} objects")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
