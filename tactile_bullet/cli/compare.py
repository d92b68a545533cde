"""``tactile-bullet compare``: every descriptor x classifier pair on the same data."""

from __future__ import annotations

import argparse
import sys

from ..errors import UsageError
from .common import emit_json, log_lines, seed_number
from .data_args import add_allow_partial, read_data, report_skipped
from .train import with_names_in_help


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "compare",
        help="compare descriptor x classifier pairs: accuracy, fit time, latency",
        description="Train and test every descriptor x classifier pair on the same data. "
        "Without --test, the data is split (seeded, stratified by shape).",
    )
    parser.add_argument("--data", required=True, metavar="DIR", help="training dataset")
    parser.add_argument("--test", metavar="DIR", help="test dataset (default: split --data)")
    add_allow_partial(parser)
    parser.add_argument(
        "--descriptor", metavar="A,B", action="append",
        help="descriptors to compare (repeatable; default: all installed)",
    )  # fmt: skip
    parser.add_argument(
        "--classifier", metavar="X,Y", action="append",
        help="classifiers to compare (repeatable; default: all installed)",
    )  # fmt: skip
    parser.add_argument(
        "--test-fraction", type=float, default=0.3,
        help="share of --data held out for testing when no --test is given (default 0.3)",
    )
    parser.add_argument("--seed", type=seed_number, default=0, help="seed of the split")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    from .common import add_hand_calibration_flag

    add_hand_calibration_flag(parser)
    parser.set_defaults(run=run)
    with_names_in_help(parser)


def name_list(text: str | list[str] | None, what: str, default) -> list[str]:
    """'a,b' -> ['a', 'b'] (no empties, no duplicates); a repeated flag's values (a list)
    joined as one list; None -> every installed name."""
    if text is None:
        return list(default())
    if isinstance(text, list):  # --classifier svm --classifier knn: both, not the last only
        text = ",".join(text)
    names = [n.strip() for n in text.split(",")]
    if not all(names):
        raise UsageError(f"{what} expects comma-separated names, got {text!r}")
    return list(dict.fromkeys(names))


def run(args: argparse.Namespace) -> int:
    from ..experiments.training import compare
    from ..plugins import classifier_names, descriptor_names

    descriptors = name_list(args.descriptor, "--descriptor", descriptor_names)
    classifiers = name_list(args.classifier, "--classifier", classifier_names)
    loaded = [read_data(args.data, args)] + ([read_data(args.test, args)] if args.test else [])
    train_records = loaded[0].records
    test_records = loaded[1].records if args.test else None
    verbose = log_lines(args.json)

    def report(row: dict) -> None:
        if verbose:
            print(f"  done {row['descriptor']} + {row['classifier']}", file=sys.stderr, flush=True)

    rows = compare(
        train_records, test_records, descriptors, classifiers,
        seed=args.seed, test_fraction=args.test_fraction, on_pair=report,
    )  # fmt: skip
    report_skipped(loaded, args, rows)
    if args.json:
        emit_json(rows)
    else:
        print(comparison_table(rows), end="")
    return 0


def comparison_table(rows: list[dict]) -> str:
    head = ("descriptor", "classifier", "accuracy", "fit (s)", "latency (ms)",
            "ambiguous (all/wrong/right)")  # fmt: skip
    body = [_cells(r) for r in rows]
    widths = [max(len(str(x)) for x in col) for col in zip(head, *body, strict=True)]
    lines = ["  ".join(str(c).ljust(w) for c, w in zip(row, widths, strict=True)).rstrip()
             for row in (head, *body)]  # fmt: skip
    skipped = [r for r in rows if r.get("skipped")]
    for r in skipped:
        lines.append(f"skipped {r['descriptor']} + {r['classifier']}: {r['skipped']}")
    if rows:
        lines.append(
            f"({rows[0]['train_records']} training and {rows[0]['test_records']} test grasps)"
        )
    return "\n".join(lines) + "\n"


def _cells(row: dict) -> tuple[str, ...]:
    if row.get("accuracy") is None:
        return (row["descriptor"], row["classifier"], "-", "-", "-", "-")
    return (
        row["descriptor"],
        row["classifier"],
        f"{100 * row['accuracy']:.1f}%",
        f"{row['fit_time_s']:.3f}",
        f"{row['predict_latency_ms']:.2f}",
        _flag_cell(row.get("ambiguous")),
    )


def _flag_cell(doubt: dict | None) -> str:
    """Shares of all, wrong and right answers flagged ambiguous ('-' where none apply)."""
    if not doubt:
        return "-"

    def pct(v) -> str:
        return "-" if v is None else f"{100 * v:.0f}%"

    keys = ("flagged", "wrong_flagged", "right_flagged")
    return "/".join(pct(doubt.get(k)) for k in keys)
