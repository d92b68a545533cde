"""How far signature + svm gets on unseen sizes and poses with richer features or model-based
training data: the two attempts docs/performance.md and docs/benchmark.md quote.

Reads the benchmark's cached full-scale sets (``tactile-bullet benchmark ... --out bench``
writes them under ``bench/data``) and prints, for in-distribution / unseen-sizes / unseen-poses:

1. signature + svm with each variant of the signature descriptor's options (``level``,
   ``alpha``, 20 points per line, floors 0 and 0.1);
2. signature + svm trained on each training grasp plus ``--copies`` synthetic ones: the true
   family's shape fit (``shape_fit.fit_family``) re-sized over the family's whole range and
   re-posed (offsets within +-10 mm, rotation within +-25 deg), or re-posed only, the grasp's
   residual from its own fit added back and J1 + J2 split as the grasp split it.

Usage: python benchmarks/signature_limits.py --cache bench/data [--copies 6] [--seed 0]
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments.benchmark import load_set
from tactile_bullet.experiments.workflow import labels_of
from tactile_bullet.hand import LONG_FINGERS
from tactile_bullet.perception import shape_fit as sf
from tactile_bullet.plugins import get_classifier, get_descriptor
from tactile_bullet.records import FCI_JOINTS

SPLITS = (("demo-train", "demo-test"), ("sizes-train", "sizes-test"),
          ("poses-train", "poses-test"))  # fmt: skip
VARIANTS = ({}, {"level": True}, {"alpha": True}, {"alpha": True, "level": True},
            {"points": 20}, {"floor": 0.0}, {"floor": 0.1})  # fmt: skip


def model_copies(record, copies: int, rng: np.random.Generator, resize: bool) -> list:
    """``copies`` synthetic versions of ``record`` from its family's fitted model."""
    fam = sf._family(record.shape)
    angles = record.fci_angles()
    fit = sf.fit_family(angles, record.shape)
    measured = sf.measured_features(angles)
    residual = measured - fit.predicted
    share = np.where(measured[1] > 1e-6, angles[1] / np.maximum(measured[1], 1e-6), 0.5)
    index = np.array([[record.joint_index(FCI_JOINTS[f][row]) for f in LONG_FINGERS]
                      for row in range(3)])  # fmt: skip
    fitted = np.array([fit.params[k] for k in fam.names])
    out = []
    while len(out) < copies:
        sizes = fam.values(rng.uniform(0, 1, fam.lo.size)[None])[0][: len(fam.names)]
        if not resize:
            span = fam.hi[: len(fam.names)] - fam.lo[: len(fam.names)]
            sizes = np.clip(fitted + rng.normal(0, 0.05, len(fitted)) * span,
                            fam.lo[: len(fam.names)], fam.hi[: len(fam.names)])  # fmt: skip
        pose = [rng.uniform(-0.01, 0.01), rng.uniform(-0.01, 0.01),
                math.radians(rng.uniform(-25, 25))]  # fmt: skip
        z = (np.concatenate([sizes, pose]) - fam.lo) / (fam.hi - fam.lo)
        if not fam.valid(z[None])[0]:
            continue
        params = {k: np.array([v]) for k, v in zip(fam.names, sizes, strict=True)}
        geometry = sf.geometric_features(fam.shape, params, np.array([pose]))
        new = sf.load_calibration().apply(geometry)[0] + residual
        final = record.final_angles.copy()
        final[index] = np.stack([new[0], new[1] * share, new[1] * (1 - share)])
        out.append(replace(record, final_angles=final))
    return out


def accuracy(desc, train, test) -> float:
    clf = get_classifier("svm").fit(desc.transform(train), labels_of(train))
    return float(np.mean(clf.predict(desc.transform(test)).astype(str) == labels_of(test)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, required=True, help="the benchmark's data folder")
    ap.add_argument("--copies", type=int, default=6)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    provenance()
    names = {n for pair in SPLITS for n in pair}
    missing = [n for n in sorted(names) if not (args.cache / n).is_dir()]
    if missing:
        sys.exit(f"{args.cache} lacks {', '.join(missing)}: run the full benchmark first")
    sets = {n: load_set(args.cache / n)[0] for n in names}
    print("signature + svm, in-distribution / unseen sizes / unseen poses (%)")
    for params in VARIANTS:
        desc = get_descriptor("signature", **params)
        scores = [100 * accuracy(desc, sets[tr], sets[te]) for tr, te in SPLITS]
        print(f"  options {params or 'default'}: " + " / ".join(f"{s:.1f}" for s in scores))
    desc = get_descriptor("signature")
    for resize, label in ((True, "re-sized and re-posed"), (False, "re-posed only")):
        rng = np.random.default_rng(args.seed)
        scores = []
        for tr, te in SPLITS:
            train = list(sets[tr])
            for record in sets[tr]:
                train += model_copies(record, args.copies, rng, resize)
            scores.append(100 * accuracy(desc, train, sets[te]))
        print(f"  trained with model copies, {label}: " + " / ".join(f"{s:.1f}" for s in scores))


if __name__ == "__main__":
    main()
