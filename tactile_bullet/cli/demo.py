"""``tactile-bullet demo``: simulate, train, test on unseen sizes and offsets, report."""

from __future__ import annotations

import argparse
import os
import sys

from .common import (
    MAX_WORKERS,
    add_engine_flag,
    add_force_flag,
    count,
    emit_json,
    engine_name,
    log_lines,
    seed_number,
    show_progress,
)

QUICK = {"train_per_shape": 4, "test_per_shape": 2}
"""A smoke-sized demo: seconds instead of minutes, for tests and a first look."""


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "demo",
        help="end-to-end demo: simulate the five thesis shapes, train, test, report",
        description="Simulate a training set and a held-out test set of the five thesis shapes "
        "(test sizes and offsets never seen in training), train signature + SVM, compare the "
        "other quick classifiers, print the confusion matrix and write a report folder.",
    )
    parser.add_argument(
        "--out", default="tactile-bullet-demo", metavar="DIR",
        help="output folder (default: ./tactile-bullet-demo)",
    )  # fmt: skip
    parser.add_argument("--seed", type=seed_number, default=0, help="seed of sizes and offsets")
    parser.add_argument(
        "--workers", type=count(1, MAX_WORKERS), default=min(2, os.cpu_count() or 1),
        help="simulation processes (default 2, or 1 on a one-core machine)",
    )  # fmt: skip
    add_force_flag(parser, "output of an earlier demo in --out")
    parser.add_argument("--quick", action="store_true", help="a tiny run (a few grasps per shape)")
    add_engine_flag(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..experiments.workflow import demo, demo_text

    engine = engine_name(args) or "bullet"
    show = show_progress(args.json)
    sizes = QUICK if args.quick else {}

    verbose = log_lines(args.json)

    def log(message: str) -> None:
        if verbose:
            print(message, file=sys.stderr, flush=True)

    doc = demo(
        args.out, seed=args.seed, workers=args.workers, show=show, log=log, force=args.force,
        engine=engine, **sizes,
    )  # fmt: skip
    if args.json:
        emit_json(doc)
    else:
        print(demo_text(doc), end="")
    return 0
