"""``tactile-bullet evaluate``: score a saved model on a labelled dataset."""

from __future__ import annotations

import argparse
from pathlib import Path

from .common import add_force_flag, emit_json, note_hand_calibration
from .data_args import add_allow_partial, read_data, report_skipped


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "evaluate",
        help="score a model on a dataset (accuracy, confusion matrix, by size and position)",
        description="Predict the shape of every grasp in a dataset with a saved model (or the "
        "default identifier) and "
        "compare with the true shapes: accuracy, confusion matrix, precision and recall per "
        "shape, accuracy by object size and by position.",
    )
    parser.add_argument(
        "--model", metavar="FILE",
        help="model file written by `train` or `adapt` (default: the built-in default "
        "identifier, the robustness matrix's winner: docs/robustness.md)",
    )  # fmt: skip
    parser.add_argument("--data", required=True, metavar="DIR", help="dataset folder or .npz")
    add_allow_partial(parser)
    parser.add_argument(
        "--report", metavar="DIR", help="write report.json and PNG figures into this folder"
    )
    add_force_flag(parser, "report files")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    from .common import add_hand_calibration_flag

    add_hand_calibration_flag(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..experiments.reports import (
        REPORT_FILES,
        report_dir,
        summary_text,
        write_evaluation_report,
    )
    from ..experiments.training import evaluate
    from ..files import existing_outputs
    from ..learn.default import resolve_model

    if args.report:
        existing_outputs(Path(args.report), REPORT_FILES, "--report folder", args.force)
    model = resolve_model(args.model)
    report = report_dir(args.report) if args.report else None
    loaded = read_data(args.data, args)
    doc = evaluate(model, loaded.records)
    report_skipped(loaded, args, doc)
    note_hand_calibration(args, doc)
    if report is not None:
        written = write_evaluation_report(doc, report)
        doc["report"] = str(report)
        doc["figures"] = [str(p) for p in written if p.suffix == ".png"]
    if args.json:
        emit_json(doc)
    else:
        print(summary_text(doc), end="")
        if report is not None:
            print(f"report: {report}")
    return 0
