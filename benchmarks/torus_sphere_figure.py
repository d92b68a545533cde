"""Picture: why the contacts name a torus that the angles read as a sphere, and why they leave
an egg unknown.

Each panel shows one grasp's contact points by where they lie along the axis of their best
torus (``perception/profile_fit.torus_fit``) and how far each lies off that torus's surface
(green) and off the best sphere's (red; the algebraic fit the profile rule makes, its radius
held to the family's range), with the default's 1 mm sphere threshold shaded. Left, MuJoCo's
torus whose tube nearly closes its hole, which the default's classifier names a sphere: its
points lie on a torus and off every sphere, so the answer is ``torus``
(``ContactCheck.contact_names``). Right, the built-in ovoid (no family): off both, so a sphere
answer for it stays ``unknown``. Prints each grasp's answers and residuals.

    python benchmarks/torus_sphere_figure.py --out docs/img/torus_for_sphere.png
"""

from __future__ import annotations

import argparse

import numpy as np
from _report import provenance, save_figure  # first: this checkout ahead of an installed copy

from tactile_bullet.learn.default import default_model
from tactile_bullet.learn.doubt import doubts
from tactile_bullet.perception.profile_fit import (
    profile_residuals,
    sphere_offsets,
    torus_fit,
    torus_residuals,
)
from tactile_bullet.records import ControllerSettings, Pose
from tactile_bullet.sim.grasp import simulate_grasp

GRASPS = (
    ("MuJoCo torus, 47 / 40 mm", "torus", {"major_radius": 0.04725, "minor_radius": 0.040125},
     "mujoco"),
    ("Bullet ovoid (no family)", "ovoid", {}, "bullet"),
)  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="docs/img/torus_for_sphere.png")
    args = ap.parse_args(argv)
    provenance(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    model = default_model()
    fig, axes = plt.subplots(1, len(GRASPS), figsize=(11, 4.5), sharey=True)
    limit = model.axis.threshold("bullet", "sphere", model.axis.profile)
    for ax, (title, shape, params, engine) in zip(axes, GRASPS, strict=True):
        record = simulate_grasp(shape, params, Pose(), ControllerSettings(engine=engine))
        names, _, was = model.answers([record])
        points = np.asarray(record.contact_position, float).reshape(-1, 3)
        fit = torus_fit(record)
        (sphere_rms,) = profile_residuals([record], ["sphere"])
        (torus_rms,) = torus_residuals([record])
        s, off = fit["along"], fit["off"]
        ax.axhspan(-1000 * limit, 1000 * limit, color="0.9", label="the sphere's threshold")
        ax.scatter(1000 * s, 1000 * off, color="tab:green", s=22, zorder=3,
                   label=f"off the best torus ({1000 * torus_rms:.2f} mm RMS)")  # fmt: skip
        ax.scatter(1000 * s, 1000 * sphere_offsets(record), color="tab:red", marker="x", s=28,
                   zorder=3, label=f"off the best sphere ({1000 * sphere_rms:.2f} mm RMS)")
        (doubt,) = doubts(model, [record], [str(names[0])], None, cross_check=False)
        answer = str(names[0]) + (f" (the classifier: {was[0]})" if was[0] else "") + (
            ", unknown" if doubt["unknown"] else "")
        ax.set_title(f"{title}: {len(points)} contact points\nthe default answers {answer}",
                     fontsize=9)  # fmt: skip
        ax.set_xlabel("contact point along the best torus's axis (mm)")
        ax.axhline(0.0, color="black", lw=0.5)
        ax.legend(fontsize=8, loc="upper left")
        print(f"{title}: answer {answer}, torus "
              f"{1000 * torus_rms:.2f} mm (R {1000 * fit['major_radius']:.1f}, r "
              f"{1000 * fit['minor_radius']:.1f}), sphere {1000 * sphere_rms:.2f} mm")  # fmt: skip
    axes[0].set_ylabel("signed distance off the surface (mm)")
    save_figure(fig, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
