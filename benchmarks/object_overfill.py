"""How far the mujoco engine's convex pieces of the concave thesis shapes reach outside the
exact surface: the torus (sectors around O-O') and the hyperboloid (slabs along it), at the
default size and at both ends of every size range.

    python benchmarks/object_overfill.py
"""

from __future__ import annotations

from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.objects.shapes import BUILTIN_SHAPES
from tactile_bullet.sim.engines.mujoco_objects import (
    object_geoms,
    overfill,
    revolved_depth,
    torus_depth,
)


def main() -> None:
    provenance()
    table = {s.name: s for s in BUILTIN_SHAPES}
    print(f"{'shape':<12}{'size':<10}{'pieces':>7}{'max mm':>8}{'mean mm':>9}")
    for name in ("torus", "hyperboloid"):
        shape = table[name]
        for label, pick in (("min", "min"), ("default", "default"), ("max", "max")):
            params = shape.resolve({k: getattr(p, pick) for k, p in shape.params.items()})
            cells = [g.vertices for g in object_geoms(shape, params)]
            if name == "torus":
                depth = lambda pts, p=params: torus_depth(pts, **p)  # noqa: E731
            else:
                depth = lambda pts, p=params, s=shape: revolved_depth(pts, s, p)  # noqa: E731
            worst, mean = overfill(cells, depth)
            print(f"{name:<12}{label:<10}{len(cells):>7}{worst * 1000:>8.3f}{mean * 1000:>9.3f}")


if __name__ == "__main__":
    main()
