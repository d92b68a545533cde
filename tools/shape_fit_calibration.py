"""Calibrate shape_fit's forward model on simulated grasps kept apart from the evaluation grid.

Reads a dataset (by default the ``thesis`` preset, e.g. ``generate --preset thesis``), keeps the
unrotated grasps of the five thesis shapes whose (shape, sizes, offset) is NOT one of
``tools/invariance.py``'s grid configurations (that grid is where the identifier is evaluated),
and fits, per finger and joint group (J3, J0 = J1 + J2), measured = intercept + gain *
geometric + side * sideways fraction by least squares at the grasps' true sizes and offsets.
The residual spread becomes each angle's sigma. The soft-L1 knee and the per-size-parameter
penalty are then chosen from small candidate sets by identification accuracy on the same
calibration grasps. Writes tactile_bullet/data/shape_fit.json. Finally it scores the fit and the
DTW matcher on the dataset's rotated grasps: the fit searches the rotation too, but none of
these grasps entered the calibration, so they say how far the model holds as the object turns
about the palm normal.

Usage: python tools/shape_fit_calibration.py --data DATASET_DIR [--no-write]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from invariance import jobs  # noqa: E402

from tactile_bullet.experiments.workflow import records_from  # noqa: E402
from tactile_bullet.objects.shapes import THESIS_SHAPES  # noqa: E402
from tactile_bullet.perception import shape_fit as sf  # noqa: E402

LOSS_SCALES = (1.0, 2.0, 4.0)
PENALTIES = (0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0)
SIGMA_FLOOR = 0.01


def config_key(shape: str, params: dict, offset) -> tuple:
    """(shape, rounded sizes, rounded offset): how a grasp configuration is recognised."""
    return (
        shape,
        tuple(sorted((k, round(float(v), 5)) for k, v in params.items())),
        tuple(round(float(v), 5) for v in offset),
    )


def evaluation_grid() -> set[tuple]:
    return {config_key(name, params, off) for name, _, params, off in jobs(quick=False)}


def regress(geometry: np.ndarray, measured: np.ndarray) -> dict:
    """Per joint group and finger: least squares of measured on (1, geometric, sideways)."""
    out = {k: np.zeros((2, 4)) for k in ("intercept", "gain", "side", "sigma")}
    for j in range(2):
        for f in range(4):
            ok = geometry[:, 2, f] >= 0  # fingers with the object under them
            x = np.column_stack([np.ones(ok.sum()), geometry[ok, j, f], geometry[ok, 2, f]])
            coef, *_ = np.linalg.lstsq(x, measured[ok, j, f], rcond=None)
            res = measured[ok, j, f] - x @ coef
            out["intercept"][j, f], out["gain"][j, f], out["side"][j, f] = coef
            out["sigma"][j, f] = max(float(res.std()), SIGMA_FLOOR)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="dataset of the thesis preset")
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()

    grid = evaluation_grid()
    chosen, excluded, rotated = [], 0, []
    for rec in records_from(args.data):
        if rec.shape not in THESIS_SHAPES:
            continue
        if rec.pose.rotation != 0.0:
            rotated.append(rec)
            continue
        if config_key(rec.shape, rec.params, rec.pose.offset) in grid:
            excluded += 1
            continue
        chosen.append(rec)
    if not chosen:
        sys.exit("no unrotated thesis-shape grasps off the evaluation grid in --data")
    geometry = np.array([
        sf.geometric_features(
            sf._TABLE[r.shape],
            {k: np.array([v]) for k, v in r.params.items()},
            np.array([[r.pose.offset[0], r.pose.offset[2]]]),
        )[0]
        for r in chosen
    ])  # fmt: skip
    measured = np.array([sf.measured_features(r.fci_angles()) for r in chosen])
    coef = regress(geometry, measured)
    raw = np.sqrt(np.mean((measured - geometry[:, :2]) ** 2))
    print(f"calibration grasps: {len(chosen)} (excluded {excluded} on the evaluation grid)")
    print(f"geometric model RMS error {raw:.3f} rad; per-angle sigma after calibration:")
    print(np.round(coef["sigma"], 3))

    truth = np.array([THESIS_SHAPES.index(r.shape) for r in chosen])
    sizes = np.array([len(sf._TABLE[n].params) for n in THESIS_SHAPES])
    best = None
    for scale in LOSS_SCALES:
        cal = sf.Calibration(**coef, loss_scale=scale, penalty=0.0)
        scores = np.array([
            [f.score for f in sf.fit_shape(r.fci_angles(), calibration=cal).fits.values()]
            for r in chosen
        ])  # fmt: skip
        for pen in PENALTIES:
            acc = float(np.mean(np.argmin(scores + pen * sizes, axis=1) == truth))
            print(f"loss_scale {scale:g} penalty {pen:g}: {acc:.1%} of calibration grasps")
            if best is None or acc > best[0]:
                best = (acc, scale, pen)
    acc, scale, pen = best
    print(f"kept loss_scale {scale:g}, penalty {pen:g} ({acc:.1%})")
    doc = sf.Calibration(**coef, loss_scale=scale, penalty=pen).to_dict()
    doc.update(
        generated_by="tools/shape_fit_calibration.py",
        grasps=len(chosen),
        excluded_on_evaluation_grid=excluded,
        calibration_accuracy=acc,
    )
    if not args.no_write:
        path = ROOT / "tactile_bullet" / "data" / "shape_fit.json"
        path.write_text(json.dumps(doc, indent=2) + "\n")
        print(f"wrote {path.relative_to(ROOT)}")
    if rotated:
        print(f"with the calibration just fitted (loss_scale {scale:g}, penalty {pen:g}):")
        rotated_rates(rotated, sf.Calibration(**coef, loss_scale=scale, penalty=pen))
        if args.no_write:
            shipped = sf.load_calibration()
            print(f"with the shipped calibration (loss_scale {shipped.loss_scale:g}, "
                  f"penalty {shipped.penalty:g}):")  # fmt: skip
            rotated_rates(rotated, shipped)


def rotated_rates(records, cal) -> None:
    """Fit and DTW identification rates on rotated grasps, per rotation (deg)."""
    from tactile_bullet.perception.patterns import identify, size_matched_library
    from tactile_bullet.perception.signature import signature_from_angles

    library = size_matched_library()
    rows = {}
    for rec in records:
        angles = rec.fci_angles()
        fit = sf.fit_shape(angles, calibration=cal).shape == rec.shape
        dtw = identify(signature_from_angles(angles), library).name == rec.shape
        rows.setdefault(round(float(np.degrees(rec.pose.rotation))), []).append((fit, dtw))
    both = [v for r in rows.values() for v in r]
    print(f"rotated grasps: {len(both)}; shape fit {np.mean([f for f, _ in both]):.1%}, "
          f"DTW {np.mean([d for _, d in both]):.1%}")  # fmt: skip
    for deg, r in sorted(rows.items()):
        print(f"  {deg:3d} deg: shape fit {np.mean([f for f, _ in r]):.1%}, "
              f"DTW {np.mean([d for _, d in r]):.1%} ({len(r)} grasps)")  # fmt: skip


if __name__ == "__main__":
    main()
