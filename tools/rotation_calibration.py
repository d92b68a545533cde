"""Calibrate the object-rotation estimate from the signature's alpha (thesis Fig. 2.25).

Simulates the torus, hyperboloid and cylinder turned 0 to 25 deg about the palm normal in
5 deg steps, at three sizes each (every parameter at 0, 25 and 50% of its range: larger ones,
turned, collide with the opposed thumb and the scene refuses them), measures alpha on the lower
line, the upper line and their mean, fits a line alpha = slope * rotation + intercept for each
(pooled, and per shape), and keeps the line whose per-shape fits have the smallest mean
absolute error (the estimate uses the identified shape's own fit). Writes
tactile_bullet/data/rotation_calibration.json and docs/img/rotation_calibration.png and prints
every fit.

Usage: python tools/rotation_calibration.py [--workers 2] [--no-write]   (about 1 min, 2 cores)
"""

from __future__ import annotations

import argparse
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tactile_bullet.objects.shapes import BUILTIN_SHAPES  # noqa: E402
from tactile_bullet.perception.patterns import (  # noqa: E402
    identify,
    size_matched_library,
    theoretical_angles,
)
from tactile_bullet.perception.rotation import LINES, alpha_of, fit_calibration, save_calibration  # noqa: E402
from tactile_bullet.perception.signature import signature_from_angles  # noqa: E402
from tactile_bullet.records import Pose  # noqa: E402

TABLE = {s.name: s for s in BUILTIN_SHAPES}
SHAPES = ("torus", "hyperboloid", "cylinder")
ROTATIONS_DEG = tuple(range(0, 30, 5))
SIZE_FRACTIONS = (0.0, 0.25, 0.5)


def sized(name: str, t: float) -> dict[str, float]:
    spec = TABLE[name]
    return spec.resolve({k: p.min + t * (p.max - p.min) for k, p in spec.params.items()})


def grasp_job(job: tuple) -> dict:
    from tactile_bullet.records import Pose
    from tactile_bullet.sim.grasp import simulate_grasp

    name, t, deg = job
    out = {"shape": name, "t": t, "deg": deg}
    try:
        rec = simulate_grasp(TABLE[name], sized(name, t), Pose(rotation=np.radians(deg)))
    except ValueError as exc:
        out["error"] = str(exc)
        return out
    out["angles"] = rec.fci_angles().tolist()
    out["flags"] = list(rec.flags)
    return out


def own_mae(cal) -> float:
    """Mean over shapes of the MAE with each shape's own fit (sample-weighted)."""
    if not cal.per_shape:
        return cal.mae_deg
    return float(np.mean([v["mae_deg_own_fit"] for v in cal.per_shape.values()]))


def plot(rows: list[dict], cal, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.8, 3.6))
    markers = {"torus": "o", "hyperboloid": "s", "cylinder": "^"}
    for k, name in enumerate(SHAPES):
        pts = np.array([(r["deg"], r["alpha"]) for r in rows if r["shape"] == name])
        if len(pts):
            ax.scatter(pts[:, 0], pts[:, 1], marker=markers[name], s=18, color=f"C{k}", alpha=0.7)
    xs = np.array([0.0, max(ROTATIONS_DEG)])
    ax.plot(xs, cal.slope * xs + cal.intercept, color="0.3", ls="--",
            label=f"pooled: R$^2$ {cal.r2:.2f}, MAE {cal.mae_deg:.1f} deg")  # fmt: skip
    for name, v in cal.per_shape.items():
        text = f"{name}: R$^2$ {v['r2']:.2f}, MAE {v['mae_deg_own_fit']:.1f} deg"
        ax.plot(xs, v["slope"] * xs + v["intercept"], color=f"C{SHAPES.index(name)}", label=text)
    ax.set_xlabel("actual rotation of the object (deg)")
    ax.set_ylabel(f"measured alpha, {cal.line} line (deg)")
    ax.set_title(f"Rotation from the signature's alpha ({cal.line} line)", fontsize=10)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()

    todo = [(n, t, d) for n in SHAPES for t in SIZE_FRACTIONS for d in ROTATIONS_DEG]
    start = time.perf_counter()
    with Pool(args.workers) as pool:
        rows = list(pool.imap(grasp_job, todo, chunksize=2))
    print(f"simulated {len(rows)} grasps in {time.perf_counter() - start:.0f} s")
    refused = [r for r in rows if "angles" not in r]
    rows = [r for r in rows if "angles" in r]
    for r in refused:
        print(f"  refused: {r['shape']} t={r['t']} {r['deg']} deg: {r['error'][:70]}")
    sigs = [signature_from_angles(np.array(r["angles"])) for r in rows]
    library = size_matched_library()
    named = [identify(sig, library).name == r["shape"] for sig, r in zip(sigs, rows, strict=True)]
    by_deg = {d: np.mean([ok for ok, r in zip(named, rows, strict=True) if r["deg"] == d])
              for d in ROTATIONS_DEG}  # fmt: skip
    print("identified (training-free) by rotation: "
          + ", ".join(f"{d} deg {v:.0%}" for d, v in by_deg.items()))  # fmt: skip
    actual = [r["deg"] for r in rows]
    names = [r["shape"] for r in rows]
    fits = {}
    for line in LINES:
        alphas = [alpha_of(s, line) for s in sigs]
        fits[line] = fit_calibration(actual, alphas, line=line, shapes=names)
        f = fits[line]
        print(f"{line:>5}: alpha = {f.slope:.3f} * rot {f.intercept:+.2f}  R2 {f.r2:.3f}  "
              f"MAE {f.mae_deg:.2f} deg")  # fmt: skip
        for shape, v in f.per_shape.items():
            own, pooled = v["mae_deg_own_fit"], v["mae_deg_pooled_fit"]
            print(f"       {shape:>11}: slope {v['slope']:.3f} R2 {v['r2']:.2f} "
                  f"MAE own fit {own:.2f}, pooled fit {pooled:.2f}")  # fmt: skip
    best = min(fits.values(), key=own_mae)
    for name in SHAPES:  # the hand model's prediction, for comparison (default size)
        turned = [
            theoretical_angles(name, pose=Pose(rotation=np.radians(d))) for d in ROTATIONS_DEG
        ]
        pred = [alpha_of(signature_from_angles(a), best.line) for a in turned]
        slope, icpt = np.polyfit(ROTATIONS_DEG, pred, 1)
        print(f"theory ({best.line} line) {name:>11}: slope {slope:.3f}, alpha(0) {icpt:+.2f}")
    clean = [i for i, r in enumerate(rows) if not r["flags"]]
    if len(clean) >= 3:
        sub = fit_calibration(
            [actual[i] for i in clean], [alpha_of(sigs[i], best.line) for i in clean],
            line=best.line,
        )  # fmt: skip
        print(f"unflagged grasps only ({len(clean)}): R2 {sub.r2:.3f} MAE {sub.mae_deg:.2f} deg")
    print(f"chosen: {best.line} line: MAE {own_mae(best):.2f} deg with each shape's own fit, "
          f"{best.mae_deg:.2f} deg pooled, over {best.samples} grasps")  # fmt: skip
    if args.no_write:
        return
    for r, s in zip(rows, sigs, strict=True):
        r["alpha"] = alpha_of(s, best.line)
    data = ROOT / "tactile_bullet" / "data"
    data.mkdir(exist_ok=True)
    path = save_calibration(best, data / "rotation_calibration.json")
    (ROOT / "docs" / "img").mkdir(parents=True, exist_ok=True)
    plot(rows, best, ROOT / "docs" / "img" / "rotation_calibration.png")
    print(f"wrote {path.relative_to(ROOT)} and docs/img/rotation_calibration.png")


if __name__ == "__main__":
    main()
