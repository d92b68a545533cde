"""Why the shape fit names the README's 30 mm cylinder a cone: every family's fit, and the
forward model's error at the true size (docs/robustness.md, root causes).

Grasps cylinders of 25, 30, 35 and 50 mm radius (Bullet, the default controller, centred) and
prints, per grasp, each family's fitted sizes, pose, RMS residual and score, then the forward
model's J0 error (model minus measured, rad, per long finger) at the cylinder's true size and
pose.

Usage: python benchmarks/cylinder_cone_fit.py
"""

from __future__ import annotations

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.learn.robust import angles_for_shape_fit
from tactile_bullet.perception import shape_fit as sf
from tactile_bullet.records import ControllerSettings, Pose
from tactile_bullet.sim.grasp import simulate_grasp

RADII = (0.025, 0.03, 0.035, 0.05)


def main() -> None:
    provenance()
    for r in RADII:
        record = simulate_grasp("cylinder", {"radius": r}, Pose(), ControllerSettings())
        angles = angles_for_shape_fit(record)
        fit = sf.fit_shape(angles)
        print(f"cylinder radius {1000 * r:.0f} mm: named {fit.shape}")
        for f in sorted(fit.fits.values(), key=lambda f: f.score):
            sizes = ", ".join(f"{k} {1000 * v:.1f}" for k, v in f.params.items())
            print(f"  {f.shape:12s} {sizes} mm; offset {np.round(np.array(f.offset) * 1000, 1)} "
                  f"mm, turned {f.rotation_deg:.1f} deg; RMS {f.residual:.4f} rad, score "
                  f"{f.score:.2f}")  # fmt: skip
        measured = sf.measured_features(angles)
        truth = sf.predicted_angles("cylinder", {"radius": r}, (0.0, 0.0))
        rms = float(np.sqrt(np.mean((truth - measured) ** 2)))
        print(f"  at the true size: RMS {rms:.4f} rad, J0 error "
              f"{np.round(truth[1] - measured[1], 3)} rad (ff, mf, rf, lf)")  # fmt: skip


if __name__ == "__main__":
    main()
