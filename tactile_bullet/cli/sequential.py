"""``tactile-bullet sequential``: offline vs sequential neural forests (thesis ch. 4)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import UsageError
from .common import add_force_flag, count, seed_number
from .data_args import add_allow_partial

if TYPE_CHECKING:
    import numpy as np

MAX_SYNTHETIC_VALUES = 20_000_000
"""Largest --synthetic data set (classes x per-class x features numbers, 160 MB of floats)."""


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "sequential",
        help="offline vs sequential neural forests: orders, updates per tree, disturbance",
        description="Learn the classes of a dataset one at a time (partial_fit) in random "
        "orders and compare with offline training; write accuracy, updates-per-tree and "
        "disturbance-matrix figures. Needs the torch extra.",
    )
    parser.add_argument("--data", type=Path, help="a dataset (generate --preset sequential)")
    add_allow_partial(parser)
    parser.add_argument("--synthetic", action="store_true", help="make_classification data")
    parser.add_argument(
        "--descriptor", default=None,
        help="unimodal (signature, raw-joints, contact-normals) or multimodal (a+b) "
        "(default signature+contact-normals)",
    )  # fmt: skip
    parser.add_argument(
        "--descriptor-param", action="append", metavar="KEY=VALUE",
        help="descriptor parameter (repeatable), e.g. points=50",
    )  # fmt: skip
    parser.add_argument("--timing", action="store_true", help="print cost figures only")
    parser.add_argument(
        "--orders", type=count(1, 1000), default=10,
        help="random orders of the classes (default 10)",
    )
    parser.add_argument(
        "--n-updates", type=count(1, 100_000), default=300,
        help="updates per new forest (default 300)",
    )
    parser.add_argument(
        "--recalibration", type=count(0, 100_000), default=100,
        help="updates per old forest (default 100)",
    )
    parser.add_argument(
        "--memory", type=count(0, 1_000_000), default=500,
        help="replay memory size in samples (default 500)",
    )
    parser.add_argument(
        "--whiten", action="store_true",
        help="train the forests' splits on whitened inputs, the classifier's default (see "
        "learn/neural_forest.py); off here, where it costs the sequential figures ~2-3 points",
    )  # fmt: skip
    parser.add_argument(
        "--classes", type=count(2, 1000), default=None,
        help="--synthetic classes (default 7)",
    )
    parser.add_argument(
        "--per-class", type=count(3, 1_000_000), default=None,
        help="--synthetic samples per class (default 300)",
    )
    parser.add_argument(
        "--features", type=count(2, 100_000), default=None, help="--synthetic features (default 40)"
    )
    parser.add_argument(
        "--latency-samples", type=count(1, 100_000), default=200,
        help="test rows timed one at a time for the prediction latency (default 200)",
    )  # fmt: skip
    parser.add_argument(
        "--seed", type=seed_number, default=0,
        help="seed of the split, the class orders and --synthetic data (default 0)",
    )  # fmt: skip
    parser.add_argument(
        "--out", type=Path, default=None,
        help="folder for the three figures, not with --timing (default sequential_experiment)",
    )  # fmt: skip
    add_force_flag(parser, "figures in --out")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


DEFAULTS = {"descriptor": "signature+contact-normals", "classes": 7, "per_class": 300,
            "features": 40, "out": Path("sequential_experiment")}  # fmt: skip
"""What the flags left out mean (their parser default is None, so that a flag given where it
means nothing is told apart from one left out)."""


def _no_contradiction(args: argparse.Namespace) -> None:
    """A flag that means nothing with the others given is refused, not silently ignored."""
    if args.synthetic and (args.descriptor is not None or args.descriptor_param):
        raise UsageError("--descriptor and --descriptor-param read grasp data: not with "
                         "--synthetic")  # fmt: skip
    if not args.synthetic:
        given = [f"--{k.replace('_', '-')}" for k in ("classes", "per_class", "features")
                 if getattr(args, k) is not None]  # fmt: skip
        if given:
            raise UsageError(f"{given[0]} sizes --synthetic data: not with --data")
    if args.timing and args.out is not None:
        raise UsageError("--out is the figures' folder: --timing writes none")


def check_args(args: argparse.Namespace) -> None:
    """Everything that can be refused before minutes of training, writing nothing: the data
    source, the size of --synthetic data, the figures' folder (no earlier figures unasked)."""
    from ..experiments.sequential import FIGURES
    from ..files import existing_outputs

    if args.synthetic and args.data is not None:
        raise UsageError("give --data DIR or --synthetic, not both")
    _no_contradiction(args)
    for name, value in DEFAULTS.items():  # the defaults, now that what was given is known
        if getattr(args, name) is None:
            setattr(args, name, value)
    if not args.synthetic:
        if args.data is None:
            raise UsageError(
                "give --data DIR (e.g. from `tactile-bullet generate --preset sequential`) or "
                "--synthetic"
            )
        if not args.data.is_dir():
            raise UsageError(f"--data {args.data} is not a dataset folder")
        from ..plugins import get_descriptor
        from .common import estimator_params

        # a typo in the descriptor or its parameters, before the dataset is read
        get_descriptor(
            args.descriptor, **estimator_params(args.descriptor_param, "--descriptor-param")
        )
    if args.synthetic:
        size = args.classes * args.per_class * args.features
        if size > MAX_SYNTHETIC_VALUES:
            raise UsageError(
                f"--synthetic data of {args.classes} x {args.per_class} x {args.features} "
                f"= {size:,} numbers is over the limit of {MAX_SYNTHETIC_VALUES:,}"
            )
    if args.timing:
        return
    out = args.out
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out} exists and is not a directory")
    existing_outputs(out, FIGURES, "--out folder", args.force)
    # writability is probed (creating the folder) once the data has loaded, before training


def run(args: argparse.Namespace) -> int:
    check_args(args)
    return _run(args)


def load_data(args: argparse.Namespace) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(X, y, class names) with y in 0..n_classes-1. The one place to wire grasp data in."""
    import numpy as np

    from ..experiments.sequential import class_name

    if args.synthetic:
        from sklearn.datasets import make_classification

        X, y = make_classification(
            n_samples=args.classes * args.per_class,
            n_features=args.features,
            n_informative=12,
            n_redundant=8,
            n_classes=args.classes,
            n_clusters_per_class=1,
            class_sep=1.5,
            random_state=args.seed,
        )
        return X, y, [f"class{c}" for c in range(args.classes)]
    if args.data is None:
        raise UsageError(
            "give --data DIR (e.g. from `tactile-bullet generate --preset sequential`) or "
            "--synthetic"
        )
    from ..datasets.dataset import read_records
    from ..plugins import get_descriptor
    from .common import estimator_params

    params = estimator_params(args.descriptor_param, "--descriptor-param")
    loaded = read_records(args.data, getattr(args, "allow_partial", False), full=False)
    args.data_skipped = loaded.as_json()  # for the --json document
    if loaded.problems:  # on stderr under --json, where stdout holds one JSON document
        import sys

        print(loaded.summary(), file=sys.stderr if getattr(args, "json", False) else sys.stdout)
    records = loaded.records
    X = get_descriptor(args.descriptor, **params).transform(records)
    names = [class_name(r) for r in records]
    classes = sorted(set(names))
    return np.asarray(X, float), np.array([classes.index(n) for n in names]), classes


def _run(args: argparse.Namespace) -> int:
    """Load the data, check it, then run the experiment or the timing and report."""
    import sys

    import numpy as np

    from ..console import emit_json
    from ..experiments.sequential import experiment, experiment_doc, plot, timing, timing_text

    json_mode = bool(getattr(args, "json", False))

    def say(text: str) -> None:
        print(text, file=sys.stderr if json_mode else sys.stdout, flush=True)

    X, y, names = load_data(args)
    counts = np.bincount(y, minlength=len(names))
    if len(names) < 2:
        raise UsageError(f"the data holds a single class ({names[0]}): nothing to learn in order")
    if counts.min() < 3:
        raise UsageError(
            f"class {names[int(counts.argmin())]!r} has {int(counts.min())} samples: the "
            "experiment holds a third of each class out for testing and needs at least 3"
        )
    if not args.timing:
        from ..files import probe_folder

        probe_folder(args.out, "--out")  # before minutes of training, not after
    if args.timing:
        doc = timing(X, y, names, args)
        if json_mode:
            emit_json(_with_skipped(doc, args))
        else:
            say(timing_text(doc))
        return 0
    found = experiment(X, y, names, args, say)
    figures = plot(found["results"], found["disturbance"], names, args.out)
    if json_mode:
        emit_json(_with_skipped(experiment_doc(found, names, args, X, figures), args))
    else:
        for path in figures:
            say(f"wrote {path}")
    return 0


def _with_skipped(doc: dict, args: argparse.Namespace) -> dict:
    """``data_skipped`` (docs/json.md) under --allow-partial, as the other commands do."""
    if getattr(args, "allow_partial", False) and hasattr(args, "data_skipped"):
        doc["data_skipped"] = args.data_skipped
    return doc
