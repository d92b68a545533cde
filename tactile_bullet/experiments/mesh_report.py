"""What ``shape-info`` reports on a processed mesh: its numbers, the primitive family whose
pattern its theoretical signature is nearest (thesis Fig. 2.27 for any object), and a figure.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ..objects.mesh_cache import cache_path
from ..objects.meshes import MeshShape
from ..objects.shapes import Shape


def nearest_family(shape: Shape) -> dict[str, Any]:
    """Which primitive family's theoretical pattern the object's own theoretical signature
    (from its r(x)) is nearest by DTW: the thesis' Fig. 2.27 for any object."""
    from ..perception.patterns import identify, pattern, size_matched_library

    sig = pattern(shape)
    ident = identify(sig, size_matched_library())
    return {"nearest": ident.nearest, "distances": ident.distances}


def describe(shape: MeshShape, profile_points: int | None = None) -> dict[str, Any]:
    """The ``shape-info --json`` document (and ``grasp --json``'s ``mesh`` block without the
    profile)."""
    src, info = shape.source, shape.info
    doc: dict[str, Any] = {
        "name": shape.name,
        "file": src.path,
        "sha256": src.sha256,
        "unit": src.unit,
        "scale": src.scale,
        "axis": {"mode": src.axis, "direction_in_file": list(info.axis)},
        "size_m": {"length": info.size[0], "y": info.size[1], "z": info.size[2]},
        "max_radius_m": info.max_radius,
        "watertight": info.watertight,
        "filled_holes": info.filled_holes,
        "triangles": {
            "input": info.triangles_in,
            "analysis": info.triangles,
            "collision": info.collision_triangles,
        },
        "simplified": info.triangles < info.triangles_in,
        "collision": "convex hull" if info.convex else "static triangle mesh",
        "cache": str(cache_path(src)),
        "pattern": nearest_family(shape),
    }
    if profile_points is not None:
        doc["radius_profile"] = {
            "definition": "perimeter of the section's convex hull / 2 pi (mean half-width)",
            "x": [float(v) for v in shape.profile_x],
            "r": [float(v) for v in shape.profile_r],
        }
    return doc


def plot_profile(shape: MeshShape, path: str | os.PathLike, dpi: int = 90) -> Path:
    """The object's r(x) (as a silhouette, fingers marked) beside its theoretical signature
    and the nearest primitive family's pattern at the matching size."""
    from ..hand import FINGER_X, LONG_FINGERS
    from ..perception.patterns import closest_in_size, pattern, size_matched_library
    from .figures_signature import _pyplot, _save

    plt = _pyplot()
    near = nearest_family(shape)
    sig = pattern(shape)
    ref = closest_in_size(sig, size_matched_library()[near["nearest"]])
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.2))
    ax = axes[0]
    x, r = shape.profile_x * 1000, shape.profile_r * 1000
    ax.fill_between(x, -r, r, color="0.85", label="equivalent section")
    ax.plot(x, shape.profile_reach * 1000, color="tab:green", lw=1, label="reach toward palm")
    for f in LONG_FINGERS:
        ax.axvline(FINGER_X[f] * 1000, color="tab:red", lw=0.8)
    ax.set_xlabel("x on O-O' (mm), fingers in red (ff right)", fontsize=8)
    ax.set_ylabel("r(x) (mm)", fontsize=8)
    ax.set_aspect("equal", adjustable="datalim")
    ax.invert_xaxis()
    ax.legend(fontsize=7)
    ax.set_title(f"{shape.name}: radius profile by slicing", fontsize=9)
    ax = axes[1]
    ax.plot(sig.upper, color="tab:blue", label="upper")
    ax.plot(sig.lower, color="tab:orange", label="lower")
    ax.plot(ref.upper, color="tab:blue", ls="--", lw=1, label=f"{near['nearest']} upper")
    ax.plot(ref.lower, color="tab:orange", ls="--", lw=1, label=f"{near['nearest']} lower")
    ax.set_ylim(-1.1, 1.1)
    ax.set_xlabel("column (ff -> lf)", fontsize=8)
    d = near["distances"][near["nearest"]]
    ax.set_title(f"theoretical signature; nearest pattern {near['nearest']} (d = {d:.1f})",
                 fontsize=9)  # fmt: skip
    ax.legend(fontsize=7, ncol=2)
    for a in axes:
        a.tick_params(labelsize=7)
    fig.tight_layout()
    return _save(fig, path, dpi)
