"""Picture of an exploration: the posterior over shapes after each grasp."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any


def plot_posteriors(doc: Mapping[str, Any], path: str | Path) -> Path:
    """One group of bars per grasp (the posterior after it), each labelled with its pose."""
    import numpy as np

    from .reports import _pyplot, _save

    plt = _pyplot()

    grasps = doc["grasps"]
    shapes = list(grasps[0]["posterior"])
    width = 0.8 / len(shapes)
    fig, ax = plt.subplots(figsize=(1.8 + 1.6 * len(grasps), 3.2))
    x = np.arange(len(grasps))
    for i, shape in enumerate(shapes):
        ax.bar(x + (i - (len(shapes) - 1) / 2) * width, [g["posterior"][shape] for g in grasps],
               width, label=shape)  # fmt: skip
    labels = []
    for k, g in enumerate(grasps, 1):
        off, rot = g["pose"]["offset"], g["pose"]["rotation_deg"]
        labels.append(f"grasp {k}\nx {1000 * off[0]:+.0f} z {1000 * off[2]:+.0f} mm\n"
                      f"{rot:+.0f} deg")  # fmt: skip
    ax.set_xticks(x, labels)
    ax.set_ylim(0, 1)
    ax.set_ylabel("posterior after the grasp")
    obj = doc.get("object", {}).get("shape", "object")
    ax.set_title(f"{obj}: {doc['answer']['shape']} after {doc['answer']['grasps']} grasp(s)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    return _save(fig, Path(path))
