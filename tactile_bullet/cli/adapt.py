"""``tactile-bullet adapt``: from a hand's known grasps to its model, in one command."""

from __future__ import annotations

import argparse

from ..console import plural
from .common import add_force_flag, emit_json, seed_number, writable_file
from .data_args import add_allow_partial


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "adapt",
        help="from your hand's known grasps to its model: try each way, keep the best",
        description="Try the ways to identify shapes on your hand (the default identifier as "
        "is; the nearest known grasp; the default's training grasps shifted to your hand with "
        "the known grasps added; with --data, the default's method trained on that set with "
        "the known grasps added) by cross-validation on the known grasps alone (folds "
        "stratified by shape, each grasp predicted by a model fitted without it), keep the "
        "best, print its expected accuracy with a 95% interval and whether more grasps per "
        "shape would help, and write it as one model file for identify --model "
        "(docs/real_hand.md).",
    )
    parser.add_argument(
        "--known", required=True, metavar="KNOWN",
        help="labelled grasps of your hand: a dataset (import --shape / --labels), record folder "
        "or record; at least 2 grasps of each of at least 2 shapes",
    )  # fmt: skip
    parser.add_argument("--out", required=True, metavar="FILE.npz", help="the model to write")
    parser.add_argument(
        "--data", metavar="DIR",
        help="also try the default's method trained on this simulated set with the known "
        "grasps added (e.g. generate --preset randomized)",
    )  # fmt: skip
    add_allow_partial(parser)
    parser.add_argument(
        "--calibrate", action="store_true",
        help="also try the shape fit calibrated to your hand on the known grasps (as calibrate "
        "does; 1-3 s per known grasp; on the hands measured it never did better: "
        "docs/performance.md)",
    )  # fmt: skip
    parser.add_argument("--seed", type=seed_number, default=0, help="folds and curve draws")
    add_force_flag(parser, "model")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import time

    from ..console import tick
    from ..experiments.adapt import adapt, build, check_known
    from ..learn.models import save_model
    from ..plugins import shape_names
    from .data_args import read_data

    start = time.perf_counter()
    out = writable_file(args.out, "--out", args.force)  # before any work
    loaded = read_data(args.known, args)
    known, unlabelled = check_known(loaded.records, shape_names())
    data = read_data(args.data, args).records if args.data else None
    doc = adapt(known, data, seed=args.seed, tick=tick, calibrate=args.calibrate)
    model = build(doc["chosen"], known, data)
    model.info["adapt"] = {k: doc[k] for k in ("chosen", "accuracy", "interval", "known_grasps",
                                               "folds", "shapes")}  # fmt: skip
    model.info["adapt"]["known"] = str(args.known)
    save_model(out, model)
    doc.update({"model": str(out), "unlabelled_skipped": unlabelled,
                "wall_time_s": time.perf_counter() - start})  # fmt: skip
    if args.json:
        emit_json(doc)
        return 0
    shapes = ", ".join(f"{n} {s}" for s, n in doc["shapes"].items())
    print(f"{plural(doc['known_grasps'], 'known grasp')} ({shapes}), {doc['folds']}"
          + (f"; {unlabelled} unlabelled left out" if unlabelled else ""))
    for row in doc["ways"]:
        lo, hi = row["interval"]
        mark = "*" if row["way"] == doc["chosen"] else " "
        print(f"{mark} {row['way']:<16} {100 * row['accuracy']:5.1f}%  "
              f"(95% {100 * lo:.0f}-{100 * hi:.0f}%)  {row['text']}")
    for way, why in doc["skipped"].items():
        print(f"  {way:<16} not tried: {why}")
    lo, hi = doc["interval"]
    print(f"chosen: {doc['chosen']}, expected accuracy on this hand {100 * doc['accuracy']:.1f}% "
          f"(95% interval {100 * lo:.0f}-{100 * hi:.0f}%, held-out known grasps)")
    if doc["curve"]:
        points = ", ".join(f"{p['per_shape']}: {100 * p['accuracy']:.0f}%" for p in doc["curve"])
        whose = doc["curve_way"]
        if whose != doc["chosen"]:  # the chosen way learns nothing from known grasps
            whose += f" (the best way that learns from known grasps; {doc['chosen']} does not)"
        print(f"learning curve of {whose} (known grasps per shape: accuracy): {points}")
    print(f"more grasps: {doc['advice']}")
    print(f"wrote model: {out} (tactile-bullet identify --model {out} ...)")
    return 0
