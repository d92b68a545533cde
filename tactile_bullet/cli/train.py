"""``tactile-bullet train``: fit a descriptor + classifier on a dataset and save the model."""

from __future__ import annotations

import argparse

from ..console import plural
from .common import add_force_flag, emit_json, estimator_params, writable_file
from .data_args import add_allow_partial, read_data, report_skipped


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "train",
        help="train a shape classifier on a dataset and save it",
        description="Compute a descriptor of every grasp in a dataset, fit a classifier on the "
        "shape names and save both (names and parameters) as one model file.",
    )
    parser.add_argument("--data", required=True, metavar="DIR", help="dataset folder or .npz")
    add_allow_partial(parser)
    parser.add_argument(
        "--descriptor", default="signature",
        help="descriptor name, a+b joins (default signature)",
    )
    parser.add_argument("--classifier", default="svm", help="classifier name (default svm)")
    parser.add_argument(
        "--param", action="append", metavar="KEY=VALUE", help="classifier parameter (repeatable)"
    )
    parser.add_argument(
        "--descriptor-param", action="append", metavar="KEY=VALUE",
        help="descriptor parameter (repeatable)",
    )  # fmt: skip
    parser.add_argument(
        "--training", choices=("clean", "noise-aware", "randomized"), default="clean",
        help="clean: the grasps as they are; noise-aware: each also read through 1 deg of joint "
        "noise (for a real hand); randomized: a dataset made with the hand drawn per grasp "
        "(generate --preset randomized), checked (default clean)",
    )  # fmt: skip
    parser.add_argument(
        "--known", metavar="DIR",
        help="grasps of your own hand whose shapes are known (an imported recording or a "
        "dataset), added to the training grasps so the model learns that hand too "
        "(docs/real_hand.md)",
    )  # fmt: skip
    parser.add_argument("--out", required=True, metavar="MODEL", help="model file to write")
    add_force_flag(parser, "model file")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)
    with_names_in_help(parser)


def with_names_in_help(parser) -> None:
    """``--help`` ends with the descriptor and classifier names installed now (built-in and
    plugins'), looked up only when help is asked for: loading plugins costs every command
    time it need not pay."""
    plain = parser.format_help

    def format_help() -> str:
        from ..plugins import classifier_names, descriptor_names

        return (plain().rstrip("\n") + "\n\ndescriptors (join with +): "
                + ", ".join(descriptor_names()) + "\nclassifiers: "
                + ", ".join(classifier_names()) + "\n")  # fmt: skip

    parser.format_help = format_help


def run(args: argparse.Namespace) -> int:
    import time

    from ..experiments.training import describe_model, train
    from ..learn.models import save_model
    from ..learn.trainings import training_records, with_known

    out = writable_file(args.out, "--out", args.force)
    params = estimator_params(args.param, "--param")
    descriptor_params = estimator_params(args.descriptor_param, "--descriptor-param")
    loaded = read_data(args.data, args)
    records = loaded.records
    known = read_data(args.known, args) if args.known else None
    fit_on = training_records(records, args.training)
    if known is not None:
        from ..plugins import get_descriptor

        desc = get_descriptor(args.descriptor, **descriptor_params)
        fit_on = with_known(fit_on, known.records, args.training, descriptor=desc)
    start = time.perf_counter()
    model = train(
        fit_on, args.descriptor, args.classifier, params, descriptor_params,
        known=known.records if known is not None else None,
    )  # fmt: skip
    fit_time = time.perf_counter() - start
    model.info.update(
        {"data": str(args.data), "train_records": len(records), "fit_time_s": fit_time,
         "training": args.training}  # fmt: skip
    )
    if known is not None:
        model.info.update({"known": str(args.known), "known_records": len(known.records)})
    if loaded.skipped_records:
        model.info["skipped_records"] = loaded.skipped_records
    path = save_model(out, model)
    doc = {
        "model": str(path),
        **describe_model(model),
        "train_records": len(records),
        "fit_time_s": fit_time,
        "training": args.training,
    }
    if known is not None:
        doc["known_records"] = len(known.records)
        doc["known_check"] = model.info.get("doubt", {}).get("known")
    report_skipped([loaded, known] if known is not None else loaded, args, doc)
    if args.json:
        emit_json(doc)
    else:
        print(
            f"trained {doc['descriptor']} + {doc['classifier']} on {plural(len(records), 'grasp')} "
            + (f"and {len(known.records)} known grasps of the hand " if known else "")
            + f"({', '.join(doc['classes'])}) in {fit_time:.2f} s, {args.training} training"
        )
        if known is not None:
            print(known_check_line(model.info.get("doubt", {}).get("known", {})))
        print(f"wrote model: {path}")
    return 0


def known_check_line(known: dict) -> str:
    """What the model's answers are checked against, and how far the check agrees with
    itself on the known grasps (docs/doubt.md)."""
    line = (f"answers are checked against the nearest of the {known.get('grasps')} known grasps "
            "(an answer it contradicts is ambiguous)")  # fmt: skip
    agreement = known.get("self_agreement")
    if agreement is None:
        return line + ("; how far the check holds is not known (a shape has one grasp, or the "
                       "grasps do not differ)")  # fmt: skip
    return line + f"; each known grasp's nearest other names its shape {100 * agreement:.0f}%"
