"""Figures of the signature: one grasp's FCI, raw and enhanced lines over the theoretical
pattern (thesis Figs 2.12, 2.18, 2.19), and the pattern gallery (Fig. 2.13).

matplotlib is imported inside each function (Agg backend) so importing this module is cheap
and works without a display.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..hand import LONG_FINGERS


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: str | Path, dpi: int) -> Path:
    """Write atomically (a failed write leaves the old file, never half a PNG) and close."""
    from ..files import atomic_path

    path = Path(path)
    try:
        with atomic_path(path, "figure") as tmp:
            fig.savefig(tmp, dpi=dpi)
    finally:
        _pyplot().close(fig)
    return path


def plot_signature(sig, path: str | Path, reference=None, title: str = "", dpi: int = 90) -> Path:
    """FCI image, raw lines, and enhanced lines (over ``reference``'s if given) in one PNG."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(10.5, 3.0))
    ax = axes[0]
    im = ax.imshow(sig.fci, cmap="gray", vmin=0, vmax=max(256.0, float(sig.fci.max())))
    ax.set_xticks(range(4), LONG_FINGERS)
    ax.set_yticks(range(3), ["J3", "J3+J2", "J3+J2+J1"])
    for (y, x), v in np.ndenumerate(sig.fci):
        ax.text(x, y, f"{v:.0f}", ha="center", va="center", fontsize=7, color="tab:red")
    ax.set_title("FCI (grey levels)", fontsize=9)
    fig.colorbar(im, ax=ax, fraction=0.046)

    ax = axes[1]
    cols = np.arange(sig.raw_lower.size)
    ax.plot(cols, sig.raw_upper, color="tab:blue", label=f"upper, alpha {sig.alpha_upper:.1f}")
    ax.plot(cols, sig.raw_lower, color="tab:orange", label=f"lower, alpha {sig.alpha_lower:.1f}")
    for line, c in ((sig.raw_upper, "tab:blue"), (sig.raw_lower, "tab:orange")):
        ax.plot([0, cols[-1]], [line[0], line[-1]], ls=":", color=c, lw=1)
    ax.set_title("raw signature S(x) (min, max of upscaled FCI)", fontsize=9)
    ax.set_xlabel("column (ff -> lf)", fontsize=8)
    ax.legend(fontsize=7)

    ax = axes[2]
    ax.plot(cols, sig.upper, color="tab:blue", label="upper")
    ax.plot(cols, sig.lower, color="tab:orange", label="lower")
    if reference is not None:
        ax.plot(cols, reference.upper, color="tab:blue", ls="--", lw=1, label="pattern upper")
        ax.plot(cols, reference.lower, color="tab:orange", ls="--", lw=1, label="pattern lower")
    ax.set_ylim(-1.1, 1.1)
    ax.set_title(f"enhanced signature (upper bulge {sig.bulge_upper:+.3f})", fontsize=9)
    ax.set_xlabel("column (ff -> lf)", fontsize=8)
    ax.legend(fontsize=7, ncol=2)
    for a in axes:
        a.tick_params(labelsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return _save(fig, path, dpi)


def plot_grasp_signature(record, path: str | Path, dpi: int = 90) -> Path:
    """One grasp's signature against the theoretical pattern of its shape at the matching size
    (or the nearest pattern's when its shape has none), titled with the identification."""
    from ..perception.patterns import closest_in_size, identify, size_matched_library
    from ..perception.signature import signature_of

    sig = signature_of(record)
    lib = size_matched_library()
    ident = identify(sig, lib)
    own = record.shape if record.shape in lib else ident.nearest
    near = ident.nearest
    title = (
        f"{record.shape}: nearest pattern {near} (d = {ident.distances[near]:.1f}), "
        f"identified as {ident.name}; dashed: {own} pattern"
    )
    return plot_signature(sig, path, closest_in_size(sig, lib[own]), title, dpi)


def plot_patterns(path: str | Path, dpi: int = 90) -> Path:
    """Gallery: each thesis shape's radius profile at the finger positions and its pattern."""
    from ..hand import FINGER_X
    from ..objects.shapes import BUILTIN_SHAPES
    from ..perception.patterns import default_library

    plt = _pyplot()
    lib = default_library()
    table = {s.name: s for s in BUILTIN_SHAPES}
    fig, axes = plt.subplots(2, len(lib), figsize=(2.4 * len(lib), 4.2))
    xs = np.linspace(0.05, -0.05, 201)
    fx = np.array([FINGER_X[f] for f in LONG_FINGERS])
    for k, (name, sig) in enumerate(lib.items()):
        spec = table[name]
        values = spec.resolve(None)
        ax = axes[0, k]
        r = spec.radius(xs, **values) * 1000
        ax.fill_between(xs * 1000, -r, r, color="0.85")
        ax.vlines(fx * 1000, -60, 60, color="tab:red", lw=0.8)
        ax.set_xlim(50, -50)
        ax.set_ylim(-95, 95)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("x on O-O' (mm), fingers in red", fontsize=7)
        ax = axes[1, k]
        ax.plot(sig.upper, color="tab:blue", label="upper")
        ax.plot(sig.lower, color="tab:orange", label="lower")
        ax.set_ylim(-1.1, 1.1)
        ax.set_xlabel("column (ff -> lf)", fontsize=7)
        for a in axes[:, k]:
            a.tick_params(labelsize=6)
    axes[1, 0].legend(fontsize=7)
    fig.suptitle("Theoretical signatures (hand wrap model, default sizes)", fontsize=10)
    fig.tight_layout()
    return _save(fig, path, dpi)
