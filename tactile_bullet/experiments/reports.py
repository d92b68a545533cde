"""Evaluation reports: scores, accuracy by object size, position and rotation, text, figures.

Scores are computed from true and predicted shape names plus the records' own metadata (sizes,
offset and rotation), so a report can say *where* recognition breaks (thesis Tables 2.1-2.2:
the ranges of size and position where the method holds), not just how often. Figures use
matplotlib's Agg backend, imported only when a figure is written, and every file is written
atomically (temporary file, then rename) so an interrupted report never leaves a half-written
PNG or JSON.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..console import json_ready, plural
from ..errors import UsageError
from ..files import atomic_path, probe_folder, write_bytes_atomic

SIZE_BINS: tuple[str, ...] = ("small", "medium", "large")
"""Thirds of the valid size range (see :func:`size_fraction`)."""

POSITION_EDGES_MM: tuple[float, ...] = (5.0, 10.0, 20.0)
"""Upper edges (mm) of the offset-distance bins; a last bin holds everything beyond."""

ROTATION_EDGES_DEG: tuple[float, ...] = (2.5, 12.5, 22.5)
"""Upper edges (deg) of the rotation bins: around the thesis' 0, 5-10, 15-20, 25 deg steps."""

BIN_DOC = {
    "size": "mean relative position of the shape's size parameters in their valid ranges "
    "(small < 1/3 <= medium < 2/3 <= large)",
    "position": "distance of the object's offset from the grasp centre (mm)",
    "rotation": "object rotation about the palm normal, absolute value (deg)",
}


# --- scores -----------------------------------------------------------------------------------


def class_order(model_classes: Sequence[str], true_labels: Sequence[str]) -> list[str]:
    """The model's classes, then any true label the model does not know (always wrong)."""
    order = [str(c) for c in model_classes]
    extra = sorted({str(t) for t in true_labels} - set(order))
    return order + extra


def confusion_matrix(
    y_true: Sequence[str], y_pred: Sequence[str], classes: Sequence[str]
) -> np.ndarray:
    """Counts (n_classes, n_classes): row = true class, column = predicted class.

    Each row sums to that class's support; predictions outside ``classes`` are not counted in
    any column (they can only come from a label the caller left out)."""
    index = {c: i for i, c in enumerate(classes)}
    cm = np.zeros((len(classes), len(classes)), dtype=int)
    for t, p in zip(y_true, y_pred, strict=True):
        if t in index and p in index:
            cm[index[t], index[p]] += 1
    return cm


def per_class_scores(cm: np.ndarray, classes: Sequence[str]) -> dict[str, dict[str, float]]:
    """Precision, recall and support of each class from a confusion matrix (0 when undefined)."""
    out = {}
    for i, name in enumerate(classes):
        support = int(cm[i].sum())
        predicted = int(cm[:, i].sum())
        hit = int(cm[i, i])
        out[name] = {
            "precision": hit / predicted if predicted else 0.0,
            "recall": hit / support if support else 0.0,
            "support": support,
        }
    return out


def size_fraction(shape: str, params: Mapping[str, float]) -> float:
    """Where an object's sizes sit in its shape's valid ranges: 0 = smallest, 1 = largest.

    The mean over the shape's parameters of (value - min) / (max - min); NaN when the shape is
    not installed or has no size parameter. One number per object lets shapes whose parameters
    differ (a sphere's radius, a torus' two radii) share the same size bins."""
    spec = _find_shape(shape)
    if spec is None:
        return math.nan
    fractions = []
    for key, p in spec.params.items():
        if key in params and p.max > p.min and p.unit == "m":
            fractions.append((float(params[key]) - p.min) / (p.max - p.min))
    return float(np.clip(np.mean(fractions), 0.0, 1.0)) if fractions else math.nan


def _find_shape(name: str):
    try:
        from ..plugins import get_shape

        return get_shape(name)
    except ImportError:
        pass
    except UsageError:
        return None
    from ..objects.shapes import BUILTIN_SHAPES

    return next((s for s in BUILTIN_SHAPES if s.name == name), None)


def size_bin(fraction: float) -> str:
    if not math.isfinite(fraction):
        return "unknown"
    return SIZE_BINS[min(int(fraction * len(SIZE_BINS)), len(SIZE_BINS) - 1)]


def _edge_bin(value: float, edges: Sequence[float], unit: str) -> str:
    low = 0.0
    for edge in edges:
        if value < edge:
            return f"{low:g}-{edge:g} {unit}"
        low = edge
    return f">={low:g} {unit}"


def _edge_labels(edges: Sequence[float], unit: str) -> list[str]:
    bounds = [0.0, *edges]
    return [f"{a:g}-{b:g} {unit}" for a, b in zip(bounds, edges, strict=False)] + [
        f">={edges[-1]:g} {unit}"
    ]


def position_bin(offset: Sequence[float]) -> str:
    """Bin label of an offset (m) by its distance from the grasp centre."""
    mm = 1000.0 * float(np.linalg.norm(np.asarray(offset, dtype=float)))
    return _edge_bin(mm, POSITION_EDGES_MM, "mm")


def rotation_bin(rotation: float) -> str:
    """Bin label of a rotation (rad) by its absolute value in degrees."""
    return _edge_bin(abs(math.degrees(float(rotation))), ROTATION_EDGES_DEG, "deg")


def _bin_order(kind: str) -> list[str]:
    if kind == "size":
        return [*SIZE_BINS, "unknown"]
    if kind == "rotation":
        return [*_edge_labels(ROTATION_EDGES_DEG, "deg"), "unknown"]
    return [*_edge_labels(POSITION_EDGES_MM, "mm"), "unknown"]


def accuracy_by(bins: Sequence[str], correct: Sequence[bool], kind: str) -> dict[str, dict]:
    """{bin: {"accuracy", "support"}} for the bins that hold records, in natural order."""
    out = {}
    bins = list(bins)
    correct = np.asarray(correct, dtype=bool)
    for label in _bin_order(kind):
        mask = np.array([b == label for b in bins], dtype=bool)
        if mask.any():
            out[label] = {"accuracy": float(correct[mask].mean()), "support": int(mask.sum())}
    return out


def evaluation_report(
    y_true: Sequence[str],
    y_pred: Sequence[str],
    classes: Sequence[str],
    records: Sequence | None = None,
) -> dict[str, Any]:
    """The ``evaluate --json`` document (docs/json.md) plus accuracy by size and position.

    ``records`` (aligned with ``y_true``) supply each object's sizes and offset for the bins;
    without them the bins are left out."""
    y_true = [str(t) for t in y_true]
    y_pred = [str(p) for p in y_pred]
    if not y_true:
        raise UsageError("nothing to evaluate: the dataset holds no records")
    if len(y_true) != len(y_pred):
        raise ValueError("y_true and y_pred differ in length")
    classes = list(classes)
    cm = confusion_matrix(y_true, y_pred, classes)
    correct = [t == p for t, p in zip(y_true, y_pred, strict=True)]
    doc: dict[str, Any] = {
        "accuracy": float(np.mean(correct)),
        "classes": classes,
        "confusion_matrix": cm.tolist(),
        "per_class": per_class_scores(cm, classes),
        "records": len(y_true),
    }
    if records is not None:
        sizes = [size_bin(size_fraction(r.shape, r.params)) for r in records]
        # a real hand's recording has no known pose: binned "unknown", not as centred
        posed = [getattr(r, "source", "simulated") == "simulated" for r in records]
        positions = [
            position_bin(r.pose.offset) if k else "unknown"
            for r, k in zip(records, posed, strict=True)
        ]
        doc["by_size"] = accuracy_by(sizes, correct, "size")
        doc["by_position"] = accuracy_by(positions, correct, "position")
        rotations = [
            rotation_bin(r.pose.rotation) if k else "unknown"
            for r, k in zip(records, posed, strict=True)
        ]
        doc["by_rotation"] = accuracy_by(rotations, correct, "rotation")
        doc["bins"] = dict(BIN_DOC)
    return doc


# --- text -------------------------------------------------------------------------------------


def confusion_text(cm: Sequence[Sequence[int]], classes: Sequence[str]) -> str:
    """The confusion matrix as an aligned table: rows true, columns predicted."""
    cm = np.asarray(cm, dtype=int)
    names = [str(c) for c in classes]
    corner = "true \\ predicted"
    first = max([len(corner)] + [len(n) for n in names])
    width = max([len(n) for n in names] + [len(str(int(cm.max(initial=0))))])
    lines = [corner.ljust(first) + "  " + " ".join(n.rjust(width) for n in names)]
    for name, row in zip(names, cm, strict=True):
        lines.append(name.ljust(first) + "  " + " ".join(str(int(v)).rjust(width) for v in row))
    return "\n".join(lines)


def summary_text(report: Mapping[str, Any]) -> str:
    """What ``evaluate`` prints on a terminal: accuracy, confusion matrix, per-bin accuracy."""
    lines = [
        f"accuracy: {100 * report['accuracy']:.1f}% on {_grasps(report)}",
        "",
        confusion_text(report["confusion_matrix"], report["classes"]),
        "",
    ]
    if report.get("no_contact"):
        lines.append(
            f"{plural(report['no_contact'], 'grasp')} touched too little to carry a shape "
            "(scored anyway)"
        )
    if report.get("unknown_classes"):
        unknown = ", ".join(report["unknown_classes"])
        lines.append(f"shapes the model was not trained on (always counted wrong): {unknown}")
    doubt = report.get("ambiguous")
    if doubt and doubt.get("flagged") is not None:
        pct = lambda v: "-" if v is None else f"{100 * v:.0f}%"  # noqa: E731
        lines.append(
            f"ambiguous: {pct(doubt['flagged'])} of answers flagged "
            f"({pct(doubt.get('wrong_flagged'))} of wrong, {pct(doubt.get('right_flagged'))} "
            "of right)"
            + ("" if doubt.get("margin") is not None else ": no calibrated margin in this model")
        )
        from ..learn.doubt import batch_warning

        answers = int(report.get("records") or 0)
        warning = batch_warning(round(doubt["flagged"] * answers), answers)
        if warning:
            lines.append(warning)
    unknown = report.get("unknown")
    if unknown and unknown.get("threshold") is not None:
        pct = lambda v: "-" if v is None else f"{100 * v:.0f}%"  # noqa: E731
        lines.append(
            f"unknown (no family the model knows): {pct(unknown['in_family'])} of "
            f"{unknown['in_family_grasps']} grasps of its shapes, {pct(unknown['out_of_family'])} "
            f"of {unknown['out_of_family_grasps']} grasps of other objects"
            + (f"; {unknown['by_axis']} because the contacts fit no solid of revolution"
               if unknown.get("by_axis") else "")
            + (f"; {unknown['by_profile']} because they fit no profile of the family named"
               if unknown.get("by_profile") else "")
        )  # fmt: skip
    blank = []
    for kind in ("by_size", "by_position", "by_rotation"):
        bins = report.get(kind)
        if bins and set(bins) == {"unknown"}:  # no grasp carries it (a real hand's recording)
            blank.append(kind.removeprefix("by_"))
        elif bins:
            parts = [f"{k} {100 * v['accuracy']:.0f}% (n={v['support']})" for k, v in bins.items()]
            lines.append(f"accuracy {kind.replace('_', ' ')}: " + ", ".join(parts))
    if blank:
        which = ", ".join(blank)
        lines.append(f"accuracy by {which}: not known (the grasps do not carry the object's "
                     f"{which}, as a recording of a real hand)")  # fmt: skip
    return "\n".join(lines).rstrip() + "\n"


# --- files ------------------------------------------------------------------------------------


def report_dir(path: str | os.PathLike) -> Path:
    """Create (if needed) and check a report folder before any long work starts."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UsageError(f"report path {path} exists and is not a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"cannot create report folder {path}: {exc.strerror or exc}") from None
    return probe_folder(path, "report folder")


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    return write_bytes_atomic(path, text.encode(), "report file")


def write_json(path: str | os.PathLike, doc: Any) -> Path:
    return write_text_atomic(path, json.dumps(json_ready(doc), indent=2) + "\n")


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    plt = _pyplot()
    try:
        with atomic_path(path, "figure") as tmp:
            fig.savefig(tmp, dpi=120, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


def plot_confusion(
    cm: Sequence[Sequence[int]], classes: Sequence[str], path: str | os.PathLike, title: str = ""
) -> Path:
    """Confusion matrix as a PNG: row-normalised colours, raw counts written in the cells."""
    plt = _pyplot()
    cm = np.asarray(cm, dtype=float)
    rows = cm.sum(axis=1, keepdims=True)
    rate = np.divide(cm, rows, out=np.zeros_like(cm), where=rows > 0)
    n = len(classes)
    fig, ax = plt.subplots(figsize=(1.2 * n + 2.5, 1.0 * n + 2))
    image = ax.imshow(rate, cmap="Blues", vmin=0.0, vmax=1.0)
    for i in range(n):
        for j in range(n):
            ax.text(
                j, i, f"{int(cm[i, j])}", ha="center", va="center",
                color="white" if rate[i, j] > 0.5 else "black",
            )  # fmt: skip
    ax.set_xticks(range(n), classes, rotation=30, ha="right")
    ax.set_yticks(range(n), classes)
    ax.set_xlabel("predicted shape")
    ax.set_ylabel("true shape")
    ax.set_title(title or "confusion matrix (colour: fraction of the true class)")
    fig.colorbar(image, ax=ax, fraction=0.046)
    return _save(fig, Path(path))


def plot_bins(
    bins: Mapping[str, Mapping[str, float]], path: str | os.PathLike, xlabel: str,
    title: str = "",
) -> Path:
    """Accuracy per bin as bars: each bar says how many of its grasps were named right
    ("6 of 8"), each tick how many grasps the bin holds, so a 100% bar of 2 grasps is not
    read like one of 50."""  # fmt: skip
    plt = _pyplot()
    labels = list(bins)
    acc = [100.0 * bins[k]["accuracy"] for k in labels]
    fig, ax = plt.subplots(figsize=(1.3 * max(len(labels), 2) + 2, 3.2))
    bars = ax.bar(range(len(labels)), acc, color="tab:blue")
    for bar, key in zip(bars, labels, strict=True):
        n = int(bins[key]["support"])
        right = round(bins[key]["accuracy"] * n)
        ax.text(
            bar.get_x() + bar.get_width() / 2, bar.get_height() + 1,
            f"{right} of {n}", ha="center", va="bottom", fontsize=8,
        )  # fmt: skip
    ticks = [f"{k}\n(n={int(bins[k]['support'])})" for k in labels]
    ax.set_xticks(range(len(labels)), ticks)
    ax.set_ylim(0, 112)
    ax.set_ylabel("accuracy (%)")
    ax.set_xlabel(xlabel)
    if title:
        ax.set_title(title, fontsize=10)
    return _save(fig, Path(path))


def _grasps(report: Mapping[str, Any]) -> str:
    """``"10 grasps"``, ``"1 grasp"``, ``"? grasps"`` where the report does not say."""
    n = report.get("records")
    return "? grasps" if n is None else plural(int(n), "grasp")


def report_title(report: Mapping[str, Any], what: str) -> str:
    """``signature + svm: 80.0% of 10 grasps; WHAT``: the method and its accuracy, so a
    figure read alone says what it scores."""
    model = report.get("model") or {}
    method = " + ".join(str(model[k]) for k in ("descriptor", "classifier") if k in model)
    score = f"{100 * report['accuracy']:.1f}% of {_grasps(report)}"
    return f"{method or 'model'}: {score}\n{what}"


REPORT_FILES: tuple[str, ...] = (
    "report.json",
    "confusion_matrix.png",
    "accuracy_by_size.png",
    "accuracy_by_position.png",
    "accuracy_by_rotation.png",
)
"""Every file :func:`write_evaluation_report` may write: checked before work so an earlier
report is never replaced unasked."""


def write_evaluation_report(report: Mapping[str, Any], out: str | os.PathLike) -> list[Path]:
    """report.json, confusion_matrix.png and the per-bin bar charts into folder ``out``."""
    out = report_dir(out)
    matrix_title = report_title(report, "confusion matrix (colour: fraction of the true class)")
    written = [
        write_json(out / "report.json", report),
        plot_confusion(
            report["confusion_matrix"], report["classes"], out / "confusion_matrix.png",
            matrix_title,
        ),
    ]  # fmt: skip
    axes = {
        "by_size": ("accuracy_by_size.png", "object size (third of the valid range)"),
        "by_position": ("accuracy_by_position.png", "offset from the grasp centre"),
        "by_rotation": ("accuracy_by_rotation.png", "object rotation about the palm normal"),
    }
    for kind, (name, label) in axes.items():
        bins = report.get(kind) or {}
        if len(bins) > (1 if kind == "by_rotation" else 0):
            title = report_title(report, f"accuracy by {kind[3:]}")
            written.append(plot_bins(bins, out / name, label, title))
    return written


def plot_signatures(records: Sequence, path: str | os.PathLike, per_shape: int = 3) -> Path:
    """Enhanced signatures (lower and upper line) of a few grasps of each shape, one panel per
    shape, over the shape's theoretical pattern: how alike grasps of one shape look across
    sizes and poses, how far they are from theory, and how unlike the other shapes."""
    from ..perception.signature import signature_of

    plt = _pyplot()
    by_shape: dict[str, list] = {}
    for rec in records:
        group = by_shape.setdefault(rec.shape, [])
        if len(group) < per_shape:
            group.append(rec)
    if not by_shape:
        raise UsageError("no records to draw signatures of")
    names = sorted(by_shape)
    fig, axes = plt.subplots(
        1, len(names), figsize=(2.9 * len(names), 3.6), sharey=True, squeeze=False
    )
    for ax, name in zip(axes[0], names, strict=True):
        for k, rec in enumerate(by_shape[name]):
            sig = signature_of(rec)
            x = np.linspace(0.0, 1.0, sig.lower.size)
            colour = f"C{k}"
            ax.plot(x, sig.lower, color=colour, lw=1.2, label=grasp_key(rec))
            ax.plot(x, sig.upper, color=colour, lw=1.2, ls="--")
        theory = _theoretical(name)
        if theory is not None:
            x = np.linspace(0.0, 1.0, theory.lower.size)
            ax.plot(x, theory.lower, color="black", lw=2.2)
            ax.plot(x, theory.upper, color="black", lw=2.2, ls="--")
        ax.set_title(name)
        ax.set_xticks([0, 1], ["ff", "lf"])
        ax.set_xlabel("finger (ff to lf)")
        ax.set_ylim(-1.15, 1.75)
        ax.set_yticks([-1.0, -0.5, 0.0, 0.5, 1.0])
        ax.legend(loc="upper center", fontsize=6.5, frameon=False, handlelength=1.2,
                  title="sizes, offset x (mm)", title_fontsize=6.5)  # fmt: skip
    axes[0][0].set_ylabel("enhanced signature")
    from matplotlib.lines import Line2D

    style = [
        Line2D([], [], color="grey", lw=1.2, label="lower line"),
        Line2D([], [], color="grey", lw=1.2, ls="--", label="upper line"),
        Line2D([], [], color="black", lw=2.2, label="theoretical pattern (default size)"),
    ]
    fig.legend(handles=style, loc="lower center", ncol=3, frameon=False,
               bbox_to_anchor=(0.5, -0.12))  # fmt: skip
    fig.suptitle("enhanced signatures of training grasps (one colour per grasp: its size and "
                 "offset in the key) and the theoretical pattern in black", y=1.02)  # fmt: skip
    return _save(fig, Path(path))


def grasp_key(record) -> str:
    """A grasp's legend entry: its sizes and offset along O-O' in mm, ``r 35, x +10``."""
    sizes = " ".join(f"{_short(k)} {1000 * v:.0f}" for k, v in record.params.items())
    return f"{sizes}, x {1000 * record.pose.offset[0]:+.0f}"


def _short(param: str) -> str:
    """``major_radius`` -> ``major r``: parameter names short enough for a legend."""
    return param.replace("radius", "r").replace("length", "len").replace("_", " ")


def _theoretical(shape: str):
    """The shape's theoretical signature, or None where theory does not cover it."""
    try:
        from ..perception.patterns import pattern

        return pattern(shape)
    except (ImportError, UsageError, KeyError):
        return None
