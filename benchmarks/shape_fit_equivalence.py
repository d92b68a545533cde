"""The shape fit's answers before and after a change: the same grasps fitted by a reference
version of ``perception/shape_fit.py`` (read from git, default: the commit before issue 30's
speed work) and by the working tree's, side by side in one process.

Inputs: the model's own angles over a grid of the five thesis shapes' sizes (every parameter
at 0, 25, 50, 75 and 100% of its range), offsets (-10, 0, +10 mm along O-O' and along the
fingers) and rotations (-20, -10, 0, 10, 20 deg), with 1 deg of Gaussian noise on every angle
(seeded); and, with ``--data DIR``, every grasp of a simulated dataset (its final angles, as
``grasp`` and the doubt cross-check read them), scored against its true shape too.

Reports: how often the two name the same family, the largest difference of the named family's
score and of every family's score, the accuracy of each on the datasets' grasps, and the median
time per grasp of each (measured alternately, grids built and cached before timing).

Usage: python benchmarks/shape_fit_equivalence.py [--ref COMMIT] [--data DIR] [--limit N]
[--no-grid] [--every N] [--set NAME=VALUE ...]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
import types

import numpy as np
from _report import REPO, provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.objects.shapes import BUILTIN_SHAPES, THESIS_SHAPES
from tactile_bullet.perception import fit_cache, shape_fit, shape_model

REFERENCE = "adcd9c0"
"""main before issue 30's speed work (the shape fit's grid search, then per-start refinement)."""

SIZE_FRACTIONS = (0.0, 0.25, 0.5, 0.75, 1.0)
OFFSETS = (-0.01, 0.0, 0.01)
ROTATIONS_DEG = (-20.0, -10.0, 0.0, 10.0, 20.0)
NOISE_RAD = np.radians(1.0)
SEARCH_CONSTANTS = ("REFINE_ROUNDS", "POLISH_STEPS", "STARTS", "REFINE_MARGIN")


def _load(commit: str, path: str, name: str, edit=lambda src: src) -> types.ModuleType:
    src = subprocess.run(
        ["git", "show", f"{commit}:tactile_bullet/perception/{path}"],
        cwd=REPO, check=True, capture_output=True, text=True,
    ).stdout  # fmt: skip
    mod = types.ModuleType(f"tactile_bullet.perception.{name}")
    mod.__package__ = "tactile_bullet.perception"
    mod.__file__ = f"<{commit}:{path}>"
    sys.modules[mod.__name__] = mod
    exec(compile(edit(src), mod.__file__, "exec"), mod.__dict__)
    return mod


def reference_module(commit: str) -> types.ModuleType:
    """``perception/shape_fit.py`` and the forward model it calls (``shape_model.py``) as they
    were at ``commit``, loaded beside the working tree's; the shapes, the placement and the
    grid's disk cache are the working tree's. The reference's calibration is the working
    tree's object, so both fits read the same coefficients."""
    model = _load(commit, "shape_model.py", "_shape_model_reference")
    model.active_calibration = shape_model.active_calibration
    model.Calibration = shape_model.Calibration
    return _load(
        commit, "shape_fit.py", "_shape_fit_reference",
        lambda src: src.replace("from .shape_model import", "from ._shape_model_reference import"),
    )  # fmt: skip


def model_grid(seed: int = 0) -> list[tuple[str, np.ndarray]]:
    """(true shape, (3, 4) angles) over the thesis shapes' sizes x offsets x rotations."""
    rng = np.random.default_rng(seed)
    table = {s.name: s for s in BUILTIN_SHAPES}
    out = []
    for name in THESIS_SHAPES:
        spec = table[name]
        for t in SIZE_FRACTIONS:
            try:
                sizes = {k: p.min + t * (p.max - p.min) for k, p in spec.params.items()}
                params = spec.resolve(sizes)
            except ValueError:
                continue
            for dx in OFFSETS:
                for dz in OFFSETS:
                    for rot in ROTATIONS_DEG:
                        try:
                            pred = shape_fit.predicted_angles(
                                name, params, (dx, dz), rotation_deg=rot
                            )
                        except Exception:  # noqa: BLE001 - an invalid combination is skipped
                            continue
                        pred = pred + rng.normal(0.0, NOISE_RAD, pred.shape)
                        out.append((name, np.stack([pred[0], 0.5 * pred[1], 0.5 * pred[1]])))
    return out


def dataset_grasps(path: str, limit: int | None) -> list[tuple[str, np.ndarray]]:
    from tactile_bullet.datasets.dataset import open_dataset
    from tactile_bullet.learn.robust import angles_for_shape_fit

    out = []
    for rec in open_dataset(path).records():
        if rec.shape in THESIS_SHAPES:
            out.append((rec.shape, angles_for_shape_fit(rec)))
        if limit and len(out) >= limit:
            break
    return out


def compare(ref, inputs, label: str) -> dict:
    same = 0
    best_diff = all_diff = fit_diff = 0.0
    moved = 0
    right_ref = right_new = 0
    t_ref, t_new = [], []
    worst = None
    for truth, angles in inputs:
        ref._FITS.clear()
        fit_cache._FITS.clear()
        t0 = time.perf_counter()
        a = ref.fit_shape(angles)
        t1 = time.perf_counter()
        b = shape_fit.fit_shape(angles)
        t2 = time.perf_counter()
        t_ref.append(t1 - t0)
        t_new.append(t2 - t1)
        same += a.shape == b.shape
        right_ref += a.shape == truth
        right_new += b.shape == truth
        d = abs(a.best.score - b.best.score)
        if d > best_diff:
            best_diff, worst = d, (truth, a.shape, b.shape, a.best.score, b.best.score)
        all_diff = max(all_diff, max(abs(a.fits[n].score - b.fits[n].score) for n in a.fits))
        if a.shape == b.shape:  # the named family's sizes, pose and residual
            x, y = a.best, b.best
            got = [*x.params.values(), *x.offset, x.rotation_deg / 1e3, x.residual]
            new = [*y.params.values(), *y.offset, y.rotation_deg / 1e3, y.residual]
            gap = float(np.max(np.abs(np.subtract(got, new))))
            fit_diff = max(fit_diff, gap)
            moved += gap > 1e-9
    n = len(inputs)
    doc = {
        "grasps": n,
        "same_family_pct": 100.0 * same / n,
        "max_named_score_diff": best_diff,
        "max_any_score_diff": all_diff,
        "max_named_fit_diff": fit_diff,
        "named_fit_differs": moved,
        "accuracy_ref_pct": 100.0 * right_ref / n,
        "accuracy_new_pct": 100.0 * right_new / n,
        "median_ms_ref": 1e3 * float(np.median(t_ref)),
        "median_ms_new": 1e3 * float(np.median(t_new)),
        "mean_ms_ref": 1e3 * float(np.mean(t_ref)),
        "mean_ms_new": 1e3 * float(np.mean(t_new)),
    }
    doc["speedup_median"] = doc["median_ms_ref"] / doc["median_ms_new"]
    doc["speedup_mean"] = doc["mean_ms_ref"] / doc["mean_ms_new"]
    print(
        f"{label}: {n} grasps; same family {doc['same_family_pct']:.1f}%; named family's score "
        f"within {best_diff:.3g} (any family's within {all_diff:.3g}; its sizes, offsets, "
        f"rotation/1000 and residual within {fit_diff:.3g}, differing by over 1e-9 on {moved}); "
        f"accuracy against the "
        f"truth {doc['accuracy_ref_pct']:.1f}% -> {doc['accuracy_new_pct']:.1f}%; per grasp "
        f"median {doc['median_ms_ref']:.1f} -> {doc['median_ms_new']:.2f} ms "
        f"({doc['speedup_median']:.1f}x), mean {doc['mean_ms_ref']:.1f} -> "
        f"{doc['mean_ms_new']:.2f} ms ({doc['speedup_mean']:.1f}x)"
    )
    if worst and best_diff > 1e-6:
        print(f"  largest named-score difference: truth, ref, new, scores = {worst}")
    return doc


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ref", default=REFERENCE, help="git commit of the reference shape_fit.py")
    ap.add_argument("--data", action="append", default=[], help="a simulated dataset (repeatable)")
    ap.add_argument("--limit", type=int, default=None, help="at most N grasps per dataset")
    ap.add_argument("--no-grid", action="store_true", help="skip the model-angle grid")
    ap.add_argument("--every", type=int, default=1,
                    help="every Nth grasp of the grid and of each dataset only")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="a search constant of the working tree's shape_fit.py changed for this "
                    "run (REFINE_ROUNDS, POLISH_STEPS, STARTS, REFINE_MARGIN): a variant "
                    "measured without editing the file")
    args = ap.parse_args(argv)
    provenance(argv)
    for item in args.set:
        name, _, value = item.partition("=")
        if name not in SEARCH_CONSTANTS:
            ap.error(f"--set {item}: not one of {', '.join(SEARCH_CONSTANTS)}")
        setattr(shape_fit, name, type(getattr(shape_fit, name))(value))
    ref = reference_module(args.ref)
    for name in THESIS_SHAPES:  # grids built (or read from the cache) before any timing
        ref.fit_shape(np.full((3, 4), 0.5))
        shape_fit.fit_shape(np.full((3, 4), 0.5))
        ref._family(name)
        shape_fit._family(name)
    if not args.no_grid:
        label = "model grid (sizes x offsets x rotations, 1 deg noise)"
        compare(ref, model_grid()[:: args.every], label)
    for path in args.data:
        grasps = dataset_grasps(path, args.limit)[:: args.every]
        if not grasps:
            print(f"dataset {path}: no grasp of the thesis shapes, nothing to compare")
            continue
        compare(ref, grasps, f"dataset {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
