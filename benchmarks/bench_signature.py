"""Speed of the signature and of the training-free identification, per grasp.

Prints the median time (over repeats, after a warm-up) of:
- the signature from final joint angles (FCI, cubic upscaling, two enhanced lines, bulges);
- one DTW distance between two 200-point lines (dtaidistance, C path, 10% band);
- identification against the five size-matched patterns (10 DTW distances, integral rule);
- the second identifier, ``shape_fit.fit_shape`` (five families fitted in size and offset to
  the absolute angles), on model angles of random sizes and offsets with 0.02 rad noise, and
  its time as a multiple of signature + DTW identification (the ratio holds under load);

Usage: python benchmarks/bench_signature.py [--repeat 2000]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.perception.patterns import (
    default_library,
    dtw_distance,
    identify,
    size_matched_library,
)
from tactile_bullet.perception.signature import signature_from_angles


def per_call(fn, args_list, repeat: int) -> float:
    """Median seconds per call over ``repeat`` calls cycling through ``args_list``."""
    for a in args_list[:10]:
        fn(*a)
    times = np.empty(repeat)
    for k in range(repeat):
        a = args_list[k % len(args_list)]
        t0 = time.perf_counter()
        fn(*a)
        times[k] = time.perf_counter() - t0
    return float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2000)
    args = ap.parse_args()
    provenance()
    rng = np.random.default_rng(0)
    angles = [(rng.uniform(0.1, 1.4, (3, 4)),) for _ in range(64)]
    sigs = [signature_from_angles(a) for (a,) in angles]
    lib = default_library()
    from dtaidistance import dtw

    print(f"dtaidistance C library: {'yes' if dtw.try_import_c() else 'NO (pure Python)'}")
    t_sig = per_call(signature_from_angles, angles, args.repeat)
    pairs = [(s.upper, r.upper) for s in sigs[:8] for r in lib.values()]
    t_dtw = per_call(dtw_distance, pairs, args.repeat)
    families = size_matched_library()
    t_id = per_call(lambda s: identify(s, families), [(s,) for s in sigs], args.repeat // 4)
    print(f"signature from angles:  {t_sig * 1e3:.3f} ms per grasp")
    print(f"DTW, 200-point lines:   {t_dtw * 1e3:.3f} ms per pair")
    print(f"identify (5 patterns):  {t_id * 1e3:.3f} ms per grasp")
    print(f"signature + identify:   {(t_sig + t_id) * 1e3:.3f} ms per grasp")
    t_fit = bench_shape_fit(rng, args.repeat // 20)
    print(f"shape fit (5 families): {t_fit * 1e3:.3f} ms per grasp "
          f"({t_fit / (t_sig + t_id):.1f}x signature + identify)")  # fmt: skip


def bench_shape_fit(rng: np.random.Generator, repeat: int) -> float:
    """Median seconds of ``fit_shape`` on noisy model angles (grids built before timing)."""
    from tactile_bullet.objects.shapes import BUILTIN_SHAPES, THESIS_SHAPES
    from tactile_bullet.perception import fit_cache, shape_fit

    table = {s.name: s for s in BUILTIN_SHAPES}
    inputs = []
    while len(inputs) < 32:
        name = THESIS_SHAPES[len(inputs) % len(THESIS_SHAPES)]
        params = {k: rng.uniform(p.min, p.max) for k, p in table[name].params.items()}
        try:
            pred = shape_fit.predicted_angles(name, params, tuple(rng.uniform(-0.01, 0.01, 2)))
        except ValueError:
            continue  # sizes the shape refuses (torus hole closed, hyperboloid inverted)
        angles = np.vstack([pred[0], pred[1] / 2, pred[1] / 2]) + rng.normal(0, 0.02, (3, 4))
        inputs.append((angles,))
    def fresh(angles):  # each call a fit, not the per-process cache's answer
        fit_cache._FITS.clear()
        return shape_fit.fit_shape(angles)

    return per_call(fresh, inputs, max(repeat, 20))


if __name__ == "__main__":
    main()
