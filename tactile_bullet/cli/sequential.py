"""``tactile-bullet sequential``: offline vs sequential neural forests (thesis ch. 4)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "sequential",
        help="offline vs sequential neural forests: orders, updates per tree, disturbance",
        description="Learn the classes of a dataset one at a time (partial_fit) in random "
        "orders and compare with offline training; write accuracy, updates-per-tree and "
        "disturbance-matrix figures. Needs the torch extra.",
    )
    parser.add_argument("--data", type=Path, help="a dataset (generate --preset sequential)")
    parser.add_argument("--synthetic", action="store_true", help="make_classification data")
    parser.add_argument(
        "--descriptor", default="signature+contact-normals",
        help="unimodal (signature, raw-joints, contact-normals) or multimodal (a+b)",
    )  # fmt: skip
    parser.add_argument(
        "--descriptor-param", action="append", metavar="KEY=VALUE",
        help="descriptor parameter (repeatable), e.g. points=50",
    )  # fmt: skip
    parser.add_argument("--timing", action="store_true", help="print cost figures only")
    parser.add_argument("--orders", type=int, default=10, help="random orders of the classes")
    parser.add_argument("--n-updates", type=int, default=300, help="updates per new forest")
    parser.add_argument("--recalibration", type=int, default=100, help="updates per old forest")
    parser.add_argument("--memory", type=int, default=500, help="replay memory size")
    parser.add_argument(
        "--no-whiten", dest="whiten", action="store_false",
        help="train the forests on standardised inputs without whitening (the model before "
        "whitening became the default; see neural_forest.py)",
    )  # fmt: skip
    parser.add_argument("--classes", type=int, default=7, help="--synthetic classes")
    parser.add_argument("--per-class", type=int, default=300, help="--synthetic samples")
    parser.add_argument("--features", type=int, default=40, help="--synthetic features")
    parser.add_argument("--latency-samples", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("sequential_experiment"))
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..sequential_experiment import run as experiment

    return experiment(args)
