"""Benchmark: grasping a large mesh file against grasping a primitive, cold and cached.

Builds two 200k-triangle solids of revolution, 12 cm long, as binary STL files in a
temporary folder: a barrel (convex: it collides as its hull, like the cylinder primitive) and
a waisted spool (concave: it collides as a static triangle mesh, like the hyperboloid
primitive). Then on one core (this process), best of --repeat each:

- the primitives' grasps: ``simulate_grasp`` on the cylinder and on the hyperboloid;
- first mesh grasp: hash + read + repair + decimate + axis + r(x) + cache write + grasp, with
  an empty cache (a fresh cache folder each repeat);
- cached mesh grasp: the same file again as a new process sees it (in-memory copies dropped,
  the disk cache kept);
- r(x) of the decimated surface against the generating profile (max error, mm).

Prints the times and the ratios the targets are set on (first < 3x, cached < 1.5x a
primitive's grasp), each mesh against the primitive that collides the same way, and the
concave one against the cylinder too. On a shared, loaded machine absolute times swing; the
ratios come from back-to-back runs.

    python benchmarks/bench_mesh.py [--triangles 200000] [--repeat 2]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
from _report import provenance, timings  # first: this checkout ahead of an installed copy

from tactile_bullet.objects import meshes
from tactile_bullet.plugins import shape_names
from tactile_bullet.sim.grasp import simulate_grasp

PROFILES = {
    # name: (radius along the axis (m), the primitive that collides the same way)
    "barrel": (lambda z: 0.038 * np.sqrt(1 - (z / 0.075) ** 2), "cylinder"),
    "spool": (lambda z: 0.03 - 0.008 * np.cos(z / 0.06 * np.pi), "hyperboloid"),
}


def write_mesh(folder: Path, name: str, triangles: int) -> Path:
    import trimesh

    rings = 400
    sections = max(8, triangles // (2 * rings))
    z = np.linspace(-0.06, 0.06, rings)
    radius = PROFILES[name][0](z)
    line = np.column_stack([np.r_[0, radius, 0], np.r_[z[0], z, z[-1]]])
    path = folder / f"{name}.stl"
    trimesh.creation.revolve(line, sections=sections).export(path)
    return path


def best(fn, repeat: int) -> float:
    return min(timings(fn, repeat))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=200_000)
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args(argv)
    provenance(None if argv is None else [sys.argv[0], *argv])
    shape_names()  # plugins loaded (and trimesh imported) before any timing
    simulate_grasp("cylinder")  # warm imports and the welded URDF
    primitive = {p: best(lambda p=p: simulate_grasp(p), args.repeat) for _, p in PROFILES.values()}
    for name, p in primitive.items():
        print(f"primitive grasp, {name}: {p:.3f} s")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name, (profile, same) in PROFILES.items():
            path = write_mesh(folder, name, args.triangles)

            def cold(path=path):
                os.environ[meshes.CACHE_ENV] = tempfile.mkdtemp(dir=folder)  # empty cache
                meshes.forget_loaded()
                simulate_grasp(meshes.load_mesh(path))

            def warm(path=path):
                meshes.forget_loaded()
                simulate_grasp(meshes.load_mesh(path))

            first, cached = best(cold, args.repeat), best(warm, args.repeat)
            shape = meshes.load_mesh(path)
            inner = slice(2, -2)  # the flat end caps are a step, not the profile
            error = 1000 * float(
                np.abs(shape.profile_r[inner] - profile(shape.profile_x[inner])).max()
            )
            info = shape.info
            kind = "convex hull" if info.convex else "triangle mesh"
            print(f"\n{name}: {info.triangles_in} triangles -> {info.triangles} analysed, "
                  f"{info.collision_triangles} in collision ({kind}); "
                  f"r(x) max error {error:.3f} mm")  # fmt: skip
            for ref in dict.fromkeys([same, "cylinder"]):
                p = primitive[ref]
                print(f"  first grasp (processing) {first:.3f} s = {first / p:.2f} x {ref} "
                      f"(target < 3); cached {cached:.3f} s = {cached / p:.2f} x {ref} "
                      "(target < 1.5)")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
