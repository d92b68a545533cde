"""Time-series baseline vs the signature on a held-out split of a simulated grid dataset, with
a first (preliminary) look at sensor noise.

The split follows the demo's idea (test sizes and offsets never seen in training) on a grid
dataset such as the ``thesis`` preset, whose sizes and offsets take a few values each:

- a record's *size* is held out when any of its shape parameters takes an interior grid value
  of odd rank among that shape's values (the middle of three; the second of four), so every
  test grasp has a parameter value no training grasp of its shape has;
- its *offset* is held out when it is off-centre along both O-O' and the fingers (the
  diagonal offsets), so training sees each offset coordinate but never those combinations;
- test = held-out size and held-out offset; train = neither; the rest is left out.

Noise (``--noise``): each test record's joint angles, series and final values alike, get a
per-joint calibration bias (each joint offset by +-b, random sign) plus Gaussian noise of
sigma per sample, and its efforts Gaussian noise of 0.02 N m; seeded. A simple stand-in for
the benchmark's perturbation model: treat its figures as preliminary.

    tactile-bullet generate --preset thesis --out thesis-data --workers 2
    python benchmarks/bench_time_series.py --data thesis-data                  # default pairs
    python benchmarks/bench_time_series.py --data DIR --pair time-series:tcn --pair signature:svm
    python benchmarks/bench_time_series.py --data DIR --noise                  # + noise table
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

DEFAULT_PAIRS = (
    "signature:svm",
    "signature:neural-forest",
    "signature+contact-normals:neural-forest",
    "raw-joints:svm",
    "time-series:svm",
    "time-series:tcn",
)

NOISE_LEVELS = ((1.0, 0.0), (0.0, 3.0), (1.0, 3.0), (2.0, 5.0))
"""(sigma deg, bias deg) on the test angles; the clean score is always printed."""

EFFORT_SIGMA = 0.02
"""N m of Gaussian effort noise added with every noise level."""


def grid_split(records) -> tuple[list, list]:
    """(train, test) records: held-out interior sizes and diagonal offsets (module doc)."""
    by_shape: dict[str, dict[str, list[float]]] = {}
    for r in records:
        for k, v in r.params.items():
            by_shape.setdefault(r.shape, {}).setdefault(k, []).append(round(float(v), 6))
    held: dict[str, dict[str, set[float]]] = {}
    for shape, params in by_shape.items():
        held[shape] = {}
        for k, values in params.items():
            grid = sorted(set(values))
            held[shape][k] = {v for i, v in enumerate(grid) if i % 2 == 1 and i < len(grid) - 1}
    train, test = [], []
    for r in records:
        size_out = any(round(float(v), 6) in held[r.shape][k] for k, v in r.params.items())
        x, _, z = r.pose.offset
        offset_out = abs(x) > 1e-6 and abs(z) > 1e-6
        if size_out and offset_out:
            test.append(r)
        elif not size_out and not offset_out:
            train.append(r)
    return train, test


def perturb(records, sigma_deg: float, bias_deg: float, seed: int) -> list:
    """Records with noisy, biased joint angles and noisy efforts (see the module doc)."""
    rng = np.random.default_rng(seed)
    out = []
    for r in records:
        n = len(r.joint_names)
        bias = np.radians(bias_deg) * rng.choice((-1.0, 1.0), n)
        sigma = np.radians(sigma_deg)
        angles = r.angles + bias + rng.normal(0.0, sigma, r.angles.shape)
        final = r.final_angles + bias + rng.normal(0.0, sigma, n)
        efforts = r.efforts + rng.normal(0.0, EFFORT_SIGMA, r.efforts.shape)
        out.append(dataclasses.replace(r, angles=angles, final_angles=final, efforts=efforts))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="a grid dataset (generate --preset thesis)")
    parser.add_argument(
        "--pair", action="append", metavar="DESCRIPTOR:CLASSIFIER",
        help=f"pair to score (repeatable; default {', '.join(DEFAULT_PAIRS)})",
    )  # fmt: skip
    parser.add_argument("--noise", action="store_true", help="also score noisy test records")
    parser.add_argument("--seed", type=int, default=0, help="seed of the noise")
    args = parser.parse_args()
    provenance()

    from tactile_bullet.experiments import workflow

    pairs = [p.split(":", 1) for p in (args.pair or DEFAULT_PAIRS)]
    if any(len(p) != 2 for p in pairs):
        parser.error("--pair takes DESCRIPTOR:CLASSIFIER")
    records = workflow.records_from(args.data)
    train, test = grid_split(records)
    print(f"{len(records)} grasps: {len(train)} train, {len(test)} test (held-out sizes, offsets)")
    noisy = {
        level: perturb(test, *level, seed=args.seed)
        for level in (NOISE_LEVELS if args.noise else ())
    }
    head = f"{'descriptor':<28}{'classifier':<15}{'fit s':>7}{'clean':>8}"
    head += "".join(f"{f's{s:g}/b{b:g}':>9}" for s, b in noisy)
    print(head + "   (accuracy %; noise: sigma/bias in deg)")
    for descriptor, classifier in pairs:
        start = time.perf_counter()
        model = workflow.train(train, descriptor, classifier)
        fit_s = time.perf_counter() - start
        scores = [workflow.evaluate(model, test)["accuracy"]]
        scores += [workflow.evaluate(model, recs)["accuracy"] for recs in noisy.values()]
        line = f"{descriptor:<28}{classifier:<15}{fit_s:>7.1f}{100 * scores[0]:>8.1f}"
        print(line + "".join(f"{100 * s:>9.1f}" for s in scores[1:]), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
