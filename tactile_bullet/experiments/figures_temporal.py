"""Figures of chapter 3: image G and Gbin with the areas of Fig 3.3, the detectors' histograms
(Figs 3.6/3.9), the decision time the dynamic detector saves (Figs 3.7/3.10), confusion matrices
(Figs 3.12/3.13) and DTW distances to the patterns (Fig 3.14).

matplotlib is imported inside each function (Agg backend), so importing this module is cheap.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..hand import LONG_FINGERS


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    from .reports import _save as save

    return save(fig, Path(path))


def plot_g_gbin(image, binary, areas, record, path: Path) -> Path:
    """G (grey levels) and Gbin side by side, time downwards, one column per finger, with each
    finger's contact time (end of area 1) and adaptation end (end of area 2.1) marked."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(7.5, 5.0), sharey=True)
    extent = (-0.5, len(LONG_FINGERS) - 0.5, image.time[-1], image.time[0])
    shown = axes[0].imshow(
        image.rows, aspect="auto", cmap="gray", extent=extent, interpolation="nearest"
    )
    fig.colorbar(shown, ax=axes[0], fraction=0.05, label="max - min of FCI column (grey)")
    axes[1].imshow(
        binary, aspect="auto", cmap="gray", extent=extent, vmin=0, vmax=1, interpolation="nearest"
    )
    for ax, title in zip(axes, ("image G", "Gbin (Sobel + threshold)"), strict=True):
        for f, area in enumerate(areas):
            if area.contact_s is not None:
                ax.plot([f - 0.45, f + 0.45], [area.contact_s] * 2, color="tab:orange", lw=2)
                ax.plot([f - 0.45, f + 0.45], [area.adapted_s] * 2, color="tab:cyan", lw=2)
        ax.set_xticks(range(len(LONG_FINGERS)), LONG_FINGERS)
        ax.set_title(title, fontsize=10)
    axes[0].set_ylabel("time (s): area 1 above orange, 2.1 to cyan, 2.2 below")
    touching = ", ".join(f for f in LONG_FINGERS if f in record.fingers_in_contact)
    offset = ", ".join(f"{1000 * v:+.0f}" for v in record.pose.offset)
    fig.suptitle(
        f"{record.shape}, offset ({offset}) mm; fingers in contact: {touching}", fontsize=9
    )
    fig.tight_layout()
    return _save(fig, path)


def plot_detectors(scores: dict, path: Path) -> Path:
    """Per detector, the 'detected' and 'measured' non-contact bars, split into right (blue)
    and wrong (grey), as thesis Figs 3.6/3.9."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(7.0, 3.4), sharey=True)
    measured = scores["measured_non_contact"]
    for ax, method in zip(axes, ("position", "dynamic"), strict=True):
        s = scores[method]
        if measured is None:  # recorded grasps: no contact truth to split right from wrong
            ax.bar([0], [s["detected_non_contact"]], color="tab:blue", label="detected")
            ax.set_xticks([0], ["detected"])
            ax.set_title(f"{method}-based (no contact truth:\nrecorded grasps)", fontsize=9)
            continue
        right = [s["detected_right"], s["measured_found"]]
        wrong = [s["false_non_contact"], s["missed_non_contact"]]
        ax.bar([0, 1], right, color="tab:blue", label="right")
        ax.bar([0, 1], wrong, bottom=right, color="0.6", label="wrong")
        ax.set_xticks([0, 1], ["detected", "measured"])
        ax.set_title(
            f"{method}-based: {100 * s['agreement']:.1f}% of fingers right\n"
            f"({measured} fingers measured without contact)",
            fontsize=9,
        )
    axes[0].set_ylabel("non-contact fingers")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def plot_saved(saved: np.ndarray, with_miss: np.ndarray, path: Path) -> Path:
    """Relative and cumulative frequency of the time (s) the dynamic detector decides before
    the position-based one (Figs 3.7/3.10), over grasps with a finger off the object."""
    plt = _pyplot()
    values = saved[with_miss] if with_miss.any() else saved
    fig, axes = plt.subplots(1, 2, figsize=(7.5, 3.2))
    bins = np.linspace(min(-0.5, values.min()), max(2.5, values.max()), 25)
    weights = np.full(values.size, 100.0 / max(values.size, 1))
    axes[0].hist(values, bins=bins, weights=weights, color="tab:blue")
    axes[0].set_xlabel("decision time saved (s)")
    axes[0].set_ylabel("% of grasps")
    xs = np.sort(values)
    axes[1].step(xs, 100.0 * np.arange(1, xs.size + 1) / max(xs.size, 1), where="post")
    axes[1].axvline(0.5, color="0.5", ls="--")
    axes[1].set_xlabel("decision time saved (s)")
    axes[1].set_ylabel("cumulative %")
    share = 100.0 * float((values > 0.5).mean()) if values.size else 0.0
    fig.suptitle(
        f"dynamic vs position-based, {values.size} grasps: median {np.median(values):.2f} s, "
        f"{share:.0f}% save > 0.5 s",
        fontsize=9,
    )
    fig.tight_layout()
    return _save(fig, path)


def plot_confusion_matrix(cm, classes, path: Path, title: str) -> Path:
    from .reports import plot_confusion

    return plot_confusion(cm, classes, path, title)


def plot_dtw(scores: dict, path: Path) -> Path:
    """DTW distance of raw and corrected signatures to their own pattern and to the others
    (Fig 3.14), with the correspondence threshold."""
    from ..perception.patterns import load_thresholds

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    data = [scores["raw"]["_own"], scores["raw"]["_other"],
            scores["corrected"]["_own"], scores["corrected"]["_other"]]  # fmt: skip
    ax.boxplot([d if d else [np.nan] for d in data], widths=0.6, flierprops={"markersize": 2})
    ax.set_xticks(
        [1, 2, 3, 4], ["raw:\nown", "raw:\nothers", "corrected:\nown", "corrected:\nothers"]
    )
    th = load_thresholds().correspondence
    if np.isfinite(th):
        ax.axhline(th, color="0.4", ls="--", label=f"correspondence threshold {th:.1f}")
        ax.legend(fontsize=8)
    ax.set_ylabel("DTW distance to pattern")
    ax.set_title(f"signatures corrected by the {scores['correction']} detector", fontsize=9)
    fig.tight_layout()
    return _save(fig, path)
