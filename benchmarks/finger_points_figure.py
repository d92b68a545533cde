"""Picture: one object grasped by several hands, each long finger's phalanges in its plane.

Draws, for each long finger (one panel each), the object's cross-section in that finger's
plane and every hand's finger as the chain knuckle - J2 - J1 - tip that ``finger-points``
reads (``learn/finger_points.py``), with each hand's J3 / J2 / J1 in the legend; prints how far
apart each pair of hands ended its fingertips. It shows what
docs/transfer.md measures: hands that divide the bend differently between their joints still
end their phalanges on the object.

The object is the ``--index``-th grasp of ``--shape`` in the first of ``--data`` (sets of the
same objects, e.g. ``benchmarks/other_hand_sets.py --hand independent`` with two hand models);
``--ours ENGINE`` grasps it again with our hand (``--servo-stiffness`` as in ``grasp``).

    python benchmarks/finger_points_figure.py --data gym-sim,ind-sim --ours mujoco --shape sphere \\
        --out docs/img/finger_points_sphere.png
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.datasets.bulk import GraspSpec, simulate_many
from tactile_bullet.experiments.workflow import records_from
from tactile_bullet.hand import FINGER_X, KNUCKLE_Z, LONG_FINGERS, PALM_HALF_THICKNESS
from tactile_bullet.learn.finger_points import finger_points
from tactile_bullet.perception.shape_model import nominal_centre
from tactile_bullet.plugins import get_shape
from tactile_bullet.records import ControllerSettings


def section(record) -> list[tuple[float, float, float]]:
    """(y, z, radius) of the object's circular section in each long finger's plane
    (unrotated objects: the axis lies along x, the palm's O-O')."""
    shape = get_shape(record.shape)
    params = {k: np.asarray(v, dtype=float) for k, v in record.params.items()}
    y0, z0 = nominal_centre(shape, params, 0.0)
    dx, dz = record.pose.offset[0], record.pose.offset[2]
    out = []
    for f in LONG_FINGERS:
        r = float(np.nan_to_num(shape.radius(np.array(FINGER_X[f] - dx), **record.params)))
        out.append((float(y0), float(z0) + dz, max(r, 0.0)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="comma list of sets of the same objects")
    ap.add_argument("--ours", help="also our hand, on this engine")
    ap.add_argument("--servo-stiffness", type=float, default=0.0)
    ap.add_argument("--shape", default="sphere")
    ap.add_argument("--index", type=int, default=0, help="which grasp of --shape")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    provenance()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sets = [Path(p) for p in args.data.split(",")]
    first = [r for r in records_from(sets[0]) if r.shape == args.shape]
    if not 0 <= args.index < len(first):
        raise SystemExit(f"{sets[0]} holds {len(first)} grasps of {args.shape}")
    target = first[args.index]
    hands = {sets[0].name: target}
    for path in sets[1:]:
        same = [r for r in records_from(path) if (r.shape, r.seed) == (target.shape, target.seed)]
        if same:
            hands[path.name] = same[0]
    if args.ours:
        ctl = ControllerSettings(engine=args.ours, servo_stiffness=args.servo_stiffness)
        spec = GraspSpec(target.shape, dict(target.params), target.pose, int(target.seed), ctl)
        (mine,), _ = simulate_many([spec])
        soft = f", servo {args.servo_stiffness:g}" if args.servo_stiffness else ""
        label = f"ours ({args.ours}{soft})"
        hands[label] = mine
    fig, axes = plt.subplots(1, 4, figsize=(13, 4), sharey=True)
    sections = section(target)
    for col, (ax, f) in enumerate(zip(axes, LONG_FINGERS, strict=True)):
        y, z, r = sections[col]
        ax.add_patch(plt.Circle((y * 1e3, z * 1e3), r * 1e3, color="0.85"))
        for name, rec in hands.items():
            pts = finger_points(rec.fci_angles())[col] * 1e3
            chain = np.vstack([[0.0, KNUCKLE_Z[f] * 1e3], pts])
            deg = [round(math.degrees(a)) for a in rec.fci_angles()[:, col]]
            ax.plot(chain[:, 0], chain[:, 1], "o-", label=f"{name}: {deg[0]}/{deg[1]}/{deg[2]}")
        ax.axvline(-PALM_HALF_THICKNESS * 1e3, color="0.5", lw=3)  # the palm's grip surface
        ax.set_title(f"{f}  (J3/J2/J1 deg)")
        ax.set_xlabel("y (mm; object side <-)")
        ax.set_aspect("equal")
        ax.legend(fontsize=7, loc="lower left")
    axes[0].set_ylabel("z (mm, along the fingers)")
    params = ", ".join(f"{k} {1e3 * v:.0f} mm" for k, v in target.params.items())
    fig.suptitle(f"{target.shape} ({params}): the phalanx ends each hand reached")
    fig.tight_layout()
    fig.savefig(args.out, dpi=90)
    print(f"wrote {args.out}")
    tips = {name: finger_points(rec.fci_angles())[:, 2] * 1e3 for name, rec in hands.items()}
    names = list(tips)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            apart = np.linalg.norm(tips[a] - tips[b], axis=1)
            print(f"fingertips {a} vs {b} (ff, mf, rf, lf): "
                  + ", ".join(f"{d:.1f}" for d in apart) + " mm")  # fmt: skip


if __name__ == "__main__":
    main()
