"""Offline vs sequential neural forests (thesis ch. 4): orders, updates per tree, disturbance.

For each of ``--orders`` random orders of the classes, a ``NeuralForestClassifier`` learns the
classes one ``partial_fit`` at a time; after each addition it is scored on the held-out samples
of the classes learned so far, next to an offline ``fit`` on the same classes. The figures:

- accuracy vs number of objects, offline and sequential (mean and spread over orders);
- updates per tree vs number of objects (thesis Fig. 4.13): mean Adam updates each class forest
  has received once k objects are known, sequential vs offline;
- disturbance matrix D[a, b]: change in the recall of class b when class a is added (mean over
  the orders in which b was already known), the thesis' "how adding shape A changes rate B".

``--timing`` instead prints the cost figures: fit time and per-sample predict latency, the time
of each ``partial_fit`` addition (which should not grow with history), offline vs sequential
accuracy.

    tactile-bullet sequential --data DIR --out figures/  # DIR from generate --preset sequential
    tactile-bullet sequential --synthetic --timing
    python benchmarks/sequential_experiment.py ...                # the same, as a tool
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.model_selection import train_test_split

from ..console import plural
from ..errors import UsageError
from ..learn.neural_forest import NeuralForestClassifier, per_class_accuracy

FIGURES: tuple[str, ...] = (
    "accuracy_vs_objects.png",
    "updates_per_tree.png",
    "disturbance_matrix.png",
)
"""The files :func:`plot` writes into ``--out``."""


def class_name(record) -> str:
    """The shape, with '-rot90' for objects turned 90 deg about the palm normal (ch. 4's extra
    classes: the same solid, another way of holding it)."""
    turned = abs(abs(record.pose.rotation) - np.pi / 2) < 0.1
    return f"{record.shape}-rot90" if turned else record.shape


def model(args: argparse.Namespace, seed: int, **overrides: Any) -> NeuralForestClassifier:
    params = {
        "n_updates": args.n_updates,
        "n_recalibration_updates": args.recalibration,
        "memory_size": args.memory,
        "whiten": getattr(args, "whiten", False),
        "random_state": seed,
    }
    return NeuralForestClassifier(**{**params, **overrides})


def split(X: np.ndarray, y: np.ndarray, seed: int) -> tuple[np.ndarray, ...]:
    return tuple(train_test_split(X, y, test_size=1 / 3, stratify=y, random_state=seed))


def run_order(
    args: argparse.Namespace, data: tuple[np.ndarray, ...], order: np.ndarray, seed: int
) -> dict:
    """Learn ``order`` one class at a time; an offline fit on the same prefix at each step."""
    X_train, X_test, y_train, y_test = data
    sequential = model(args, seed)
    n_classes = len(order)
    result = {
        "seq_acc": [],
        "off_acc": [],
        "seq_updates": [],
        "off_updates": [],
        "recall": np.full((n_classes, n_classes), np.nan),  # step x class
        "seconds": [],
    }
    from ..console import tick

    for step, label in enumerate(order):
        tick(f"sequential order (seed {seed}): classes learnt", step, n_classes)
        known = order[: step + 1]
        train, test = np.isin(y_train, known), np.isin(y_test, known)
        new = y_train == label
        start = time.perf_counter()
        sequential.partial_fit(X_train[new], y_train[new])
        result["seconds"].append(time.perf_counter() - start)
        result["seq_acc"].append(sequential.score(X_test[test], y_test[test]))
        result["seq_updates"].append(float(sequential.n_updates_.mean()))
        recall = per_class_accuracy(sequential, X_test[test], y_test[test], labels=known)
        for c, value in recall.items():
            result["recall"][step, c] = value
        offline = model(args, seed).fit(X_train[train], y_train[train])
        result["off_acc"].append(offline.score(X_test[test], y_test[test]))
        result["off_updates"].append(float(offline.n_updates_.mean()))
    return result


def disturbance(results: list[dict], orders: list[np.ndarray], n_classes: int) -> np.ndarray:
    """D[a, b]: mean change of class b's recall in the step that added class a."""
    total = np.zeros((n_classes, n_classes))
    count = np.zeros((n_classes, n_classes))
    for result, order in zip(results, orders, strict=True):
        recall = result["recall"]
        for step in range(1, n_classes):
            a = order[step]
            for b in order[:step]:
                total[a, b] += recall[step, b] - recall[step - 1, b]
                count[a, b] += 1
    with np.errstate(invalid="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def clipped_spread(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean over the rows (orders) of accuracies, and how far +-1 std reaches below and above
    it, cut at 0 and 1: a bar past 100% would show an accuracy no order can have."""
    mean, std = values.mean(axis=0), values.std(axis=0)
    return mean, np.minimum(std, mean), np.minimum(std, 1.0 - mean)


def plot(results: list[dict], matrix: np.ndarray, names: list[str], out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"cannot create --out {out}: {exc.strerror or exc}") from None
    k = np.arange(1, len(names) + 1)
    paths = []

    fig, ax = plt.subplots(figsize=(5, 3.5))
    for key, label in (("off_acc", "offline"), ("seq_acc", "sequential")):
        values = np.array([r[key] for r in results], dtype=float)
        mean, below, above = clipped_spread(values)
        ax.errorbar(k, mean, yerr=[below, above], marker="o", capsize=3, label=label)
    ax.set(xlabel="number of objects learnt", ylabel="test accuracy (known objects)",
           ylim=(0, 1.02))  # fmt: skip
    ax.set_xticks(k)
    ax.legend()
    ax.set_title(f"offline vs sequential learning\n(mean and std over {len(results)} orders)",
                 fontsize=10)  # fmt: skip
    paths.append(out / FIGURES[0])
    _save(fig, paths[-1])

    fig, ax = plt.subplots(figsize=(5, 3.5))
    for key, label in (("off_updates", "offline"), ("seq_updates", "sequential")):
        ax.plot(k, np.mean([r[key] for r in results], axis=0), marker="o", label=label)
    ax.set(xlabel="number of objects learnt", ylabel="mean updates per tree")
    ax.legend()
    ax.set_title("updates per tree as objects are learnt", fontsize=10)
    ax.set_xticks(k)
    paths.append(out / FIGURES[1])
    _save(fig, paths[-1])

    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    measured = np.isfinite(matrix)
    limit = max(0.05, float(np.abs(matrix[measured]).max())) if measured.any() else 0.05
    # "not measured" (a class with itself, pairs no order met) is grey, not the colour of 0
    cmap = plt.get_cmap("RdBu").with_extremes(bad="0.8")
    image = ax.imshow(np.ma.masked_invalid(matrix), cmap=cmap, vmin=-limit, vmax=limit)
    for a, b in zip(*np.nonzero(~measured), strict=True):
        ax.text(b, a, "-", ha="center", va="center", color="0.4", fontsize=8)
    ax.set_xticks(range(len(names)), names, rotation=45, ha="right")
    ax.set_yticks(range(len(names)), names)
    ax.set(xlabel="class b (recall changes)", ylabel="class a (added)")
    ax.set_title("disturbance: change in b's recall when a is learnt\n(grey '-': not measured)",
                 fontsize=10)  # fmt: skip
    fig.colorbar(image, ax=ax, label="change in recall of b")
    paths.append(out / FIGURES[2])
    _save(fig, paths[-1])
    return paths


def _save(fig, path: Path) -> None:
    """Write a figure atomically (never a half-written PNG) and close it."""
    import matplotlib.pyplot as plt

    from ..files import atomic_path

    try:
        fig.tight_layout()
        with atomic_path(path, "figure") as tmp:
            fig.savefig(tmp, dpi=120)
    finally:
        plt.close(fig)


def experiment(
    X: np.ndarray, y: np.ndarray, names: list[str], args: argparse.Namespace, say=print
) -> dict:
    """All three experiments on (X, y, names); returns the raw results and the matrix.
    ``say`` receives the progress and summary lines (stdout, or stderr under --json)."""
    data = split(X, y, args.seed)
    rng = np.random.default_rng(args.seed)
    orders = [rng.permutation(len(names)) for _ in range(args.orders)]
    results = []
    for i, order in enumerate(orders):
        result = run_order(args, data, order, args.seed + i)
        results.append(result)
        say(
            f"order {i}: {[names[c] for c in order]} offline {result['off_acc'][-1]:.3f} "
            f"sequential {result['seq_acc'][-1]:.3f}"
        )
    matrix = disturbance(results, orders, len(names))
    final_off = [r["off_acc"][-1] for r in results]
    final_seq = [r["seq_acc"][-1] for r in results]
    say(
        f"final accuracy over {plural(len(orders), 'order')}: offline {np.mean(final_off):.3f} "
        f"+- {np.std(final_off):.3f}, sequential {np.mean(final_seq):.3f} "
        f"+- {np.std(final_seq):.3f}"
    )
    if np.isfinite(matrix).any():
        say(
            f"mean disturbance (off-diagonal): {np.nanmean(matrix):+.3f}, "
            f"worst {np.nanmin(matrix):+.3f}"
        )
    say(disturbance_table(matrix, names))
    return {"results": results, "orders": orders, "disturbance": matrix}


def disturbance_table(matrix: np.ndarray, names: list[str]) -> str:
    """D[a, b] as text, every class name in full (columns as wide as the longest)."""
    width = max(7, *(len(n) for n in names))
    lines = ["disturbance D[a, b] (row a added, column b):"]
    lines.append(" " * (width + 1) + " ".join(f"{n:>{width}}" for n in names))
    for name, row in zip(names, matrix, strict=True):
        cells = " ".join(f"{v:>+{width}.3f}" if np.isfinite(v) else f"{'-':>{width}}" for v in row)
        lines.append(f"{name:>{width}} {cells}")
    return "\n".join(lines)


def _mean_std(values) -> dict[str, float]:
    return {"mean": float(np.mean(values)), "std": float(np.std(values))}


def _finite_or_none(matrix: np.ndarray) -> list[list[float | None]]:
    return [[float(v) if np.isfinite(v) else None for v in row] for row in matrix]


def experiment_doc(found: dict, names: list[str], args, X: np.ndarray, figures) -> dict:
    """The ``sequential --json`` document of the experiment."""
    results, matrix = found["results"], found["disturbance"]
    curves = {
        key: {
            "offline": np.mean([r[f"off_{key}"] for r in results], axis=0).tolist(),
            "sequential": np.mean([r[f"seq_{key}"] for r in results], axis=0).tolist(),
        }
        for key in ("acc", "updates")
    }
    finite = matrix[np.isfinite(matrix)]
    return {
        "classes": list(names),
        "samples": int(X.shape[0]),
        "features": int(X.shape[1]),
        "descriptor": None if args.synthetic else args.descriptor,
        "orders": [[names[c] for c in order] for order in found["orders"]],
        "final_accuracy": {
            "offline": _mean_std([r["off_acc"][-1] for r in results]),
            "sequential": _mean_std([r["seq_acc"][-1] for r in results]),
        },
        "accuracy_vs_objects": curves["acc"],
        "updates_per_tree": curves["updates"],
        "disturbance": {
            "matrix": _finite_or_none(matrix),
            "mean": float(finite.mean()) if finite.size else None,
            "worst": float(finite.min()) if finite.size else None,
        },
        "figures": [str(p) for p in figures],
    }


def timing(X: np.ndarray, y: np.ndarray, names: list[str], args: argparse.Namespace) -> dict:
    """Fit time, per-sample latency, per-addition time, offline vs sequential accuracy."""
    X_train, X_test, y_train, y_test = split(X, y, args.seed)
    model(args, args.seed, n_updates=2).fit(X_train, y_train)  # import torch, warm up
    start = time.perf_counter()
    offline = model(args, args.seed).fit(X_train, y_train)
    fit_s = time.perf_counter() - start
    latencies = []
    for row in X_test[: args.latency_samples]:
        start = time.perf_counter()
        offline.predict(row[None, :])
        latencies.append(time.perf_counter() - start)
    start = time.perf_counter()
    offline.predict(X_test)
    batch_s = time.perf_counter() - start
    sequential = model(args, args.seed)
    additions = []
    for label in range(len(names)):
        new = y_train == label
        start = time.perf_counter()
        sequential.partial_fit(X_train[new], y_train[new])
        additions.append(time.perf_counter() - start)
    return {
        "classes": list(names),
        "train_samples": int(len(y_train)),
        "test_samples": int(len(y_test)),
        "features": int(X.shape[1]),
        "n_updates": args.n_updates,
        "n_recalibration_updates": args.recalibration,
        "memory_size": args.memory,
        "fit_time_s": fit_s,
        "predict_latency_ms": 1e3 * statistics.median(latencies),
        "predict_batch_us_per_sample": 1e6 * batch_s / len(X_test),
        "add_class_s": additions,
        "accuracy": {
            "offline": float(offline.score(X_test, y_test)),
            "sequential": float(sequential.score(X_test, y_test)),
        },
    }


def timing_text(doc: dict) -> str:
    return "\n".join(
        [
            f"data: {len(doc['classes'])} classes, {doc['train_samples']} train / "
            f"{doc['test_samples']} test samples x {doc['features']} features; "
            f"n_updates={doc['n_updates']}, n_recalibration_updates="
            f"{doc['n_recalibration_updates']}, memory_size={doc['memory_size']}",
            f"offline fit: {doc['fit_time_s']:.2f} s",
            f"predict one sample: median {doc['predict_latency_ms']:.3f} ms; batch of "
            f"{doc['test_samples']}: {doc['predict_batch_us_per_sample']:.1f} us/sample",
            "partial_fit per added class (s): " + " ".join(f"{s:.2f}" for s in doc["add_class_s"]),
            f"accuracy: offline {doc['accuracy']['offline']:.3f}, "
            f"sequential {doc['accuracy']['sequential']:.3f}",
        ]
    )
