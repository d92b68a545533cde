"""``tactile-bullet temporal``: chapter 3's analysis of a set of grasps (figures and JSON)."""

from __future__ import annotations

import argparse

from .common import emit_json


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "temporal",
        help="temporal analysis (thesis ch. 3): image G, non-contact fingers, corrected SVMs",
        description="Image G and Gbin of one grasp with its areas, both non-contact finger "
        "detectors against the recorded contacts, the decision time the dynamic one saves, "
        "SVM_pos / SVM_dyn against the uncorrected SVM on centred and off-centre objects, and "
        "DTW distances of corrected signatures: PNG figures and temporal.json in --out.",
    )
    parser.add_argument("--data", required=True, metavar="DIR", help="dataset folder or .npz")
    parser.add_argument("--out", required=True, metavar="DIR", help="folder for figures + JSON")
    parser.add_argument(
        "--example", type=int, metavar="N",
        help="record whose G and Gbin are drawn (default: the first with a finger off the object)",
    )  # fmt: skip
    parser.add_argument("--force", action="store_true", help="overwrite existing output files")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..experiments.temporal import check_outputs, run_experiment, summary_text
    from ..experiments.training import records_from

    check_outputs(args.out, args.force)
    doc = run_experiment(records_from(args.data), args.out, args.force, args.example)
    if args.json:
        emit_json(doc)
    else:
        print(summary_text(doc), end="")
    return 0
