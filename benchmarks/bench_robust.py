"""Cost of the sensor model and of the robust descriptors, per grasp.

Prints the median time (over repeats, after a warm-up) of:
- ``perturb`` (joint noise + calibration bias + effort noise on a whole grasp's series, final
  angles and contact normals);
- the plain ``signature`` descriptor and ``robust-signature`` (zeroing on the open hand and
  tail averaging, then the same signature) on one record, so the robustness's price is the
  difference;
- ``augment`` per training record (4 perturbed copies, the benchmark's noise-aware training).

Records are synthetic (the wrapping theory, 160 samples: a 2.7 s grasp at 60 Hz), so the
script needs no simulator.

Usage: python benchmarks/bench_robust.py [--repeat 500]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from _report import REPO, provenance  # first: this checkout ahead of an installed copy

sys.path.insert(0, str(REPO / "tests"))  # tests/synthetic.py: records without a simulator

from synthetic import make_records  # noqa: E402

from tactile_bullet.learn.perturb import SensorModel, perturb  # noqa: E402
from tactile_bullet.learn.robust import augment  # noqa: E402
from tactile_bullet.plugins import get_descriptor  # noqa: E402


def per_call(fn, items, repeat: int) -> float:
    """Median seconds per call over ``repeat`` calls cycling through ``items``."""
    for item in items[:5]:
        fn(item)
    times = np.empty(repeat)
    for k in range(repeat):
        item = items[k % len(items)]
        t0 = time.perf_counter()
        fn(item)
        times[k] = time.perf_counter() - t0
    return float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=500)
    args = ap.parse_args()
    provenance()
    from synthetic import make_record

    records = make_records(per_shape=4, seed=0)
    records = [make_record(r.shape, r.params, np.random.default_rng(i), samples=160)
               for i, r in enumerate(records)]  # fmt: skip
    model = SensorModel.degrees(sigma=1.0, bias=3.0, effort_sigma=0.02)
    t_perturb = per_call(lambda r: perturb(r, model, 0), records, args.repeat)
    plain, robust = get_descriptor("signature"), get_descriptor("robust-signature")
    t_plain = per_call(lambda r: plain.transform([r]), records, args.repeat)
    t_robust = per_call(lambda r: robust.transform([r]), records, args.repeat)
    runs = []
    for _ in range(5):  # best of 5: one call covers every record
        t0 = time.perf_counter()
        augment(records, copies=4)
        runs.append((time.perf_counter() - t0) / len(records))
    t_aug = min(runs)
    print(f"perturb (sigma 1 deg, bias 3 deg, effort): {t_perturb * 1e3:.3f} ms per grasp")
    print(f"signature descriptor:                      {t_plain * 1e3:.3f} ms per grasp")
    print(f"robust-signature descriptor:               {t_robust * 1e3:.3f} ms per grasp")
    print(f"augment, 4 copies:                         {t_aug * 1e3:.3f} ms per training grasp")


if __name__ == "__main__":
    main()
