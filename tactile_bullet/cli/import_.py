"""``tactile-bullet import``: real-hand recordings (ROS bags, CSV, Parquet) into a dataset."""

from __future__ import annotations

import argparse

from ..console import plural
from ..errors import UsageError
from .common import emit_json, parse_number


def add_recording_options(parser: argparse.ArgumentParser) -> None:
    """Options shared by every command that reads recordings (import, identify)."""
    parser.add_argument(
        "--topic", default="/joint_states", help="JointState topic of a bag (default /joint_states)"
    )
    parser.add_argument(
        "--marker", metavar="TOPIC|COLUMN",
        help="grasp start/end marker: a bag topic (std_msgs String or Bool) or a table column; "
        "default: the one `export` writes when present, else silence between closures; "
        "'none' ignores the file's markers",
    )  # fmt: skip
    parser.add_argument(
        "--gap", default="0.5", metavar="S",
        help="silence (s) without messages that ends a grasp (default 0.5)",
    )  # fmt: skip
    parser.add_argument(
        "--calibration", metavar="FILE.toml", help="per-joint offsets and scales (TOML)"
    )
    parser.add_argument(
        "--prefix", metavar="PREFIX",
        help="the hand to read where a file holds two (rh_, lh_; 'none' for unprefixed "
        "names); a file of two hands is refused without it",
    )  # fmt: skip


def recording_options(args: argparse.Namespace) -> dict:
    """The keyword arguments of ``recordings.read_recording`` from the shared options."""
    from ..realhand.calibration import load_calibration

    gap = parse_number(args.gap, "--gap")
    if gap <= 0:
        raise UsageError(f"--gap must be positive, got {args.gap}")
    calibration = load_calibration(args.calibration) if args.calibration else None
    from ..realhand.names import prefix_option

    return {"topic": args.topic, "marker": args.marker, "gap_s": gap, "calibration": calibration,
            "prefix": prefix_option(args.prefix)}  # fmt: skip


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "import",
        help="read real-hand recordings (ROS bags, CSV, Parquet) into a dataset",
        description="Cut the grasps out of joint-state recordings (ROS 1 .bag, ROS 2 bag "
        "folders with .db3 or .mcap storage, CSV, Parquet) and write them as a dataset that "
        "train, evaluate, compare and identify read like a simulated one.",
    )
    parser.add_argument("files", nargs="+", metavar="FILE", help="recordings to read")
    parser.add_argument("--out", required=True, metavar="DIR", help="dataset folder to write")
    parser.add_argument(
        "--shape", metavar="NAME",
        help="label every grasp with this shape (recordings of a known object)",
    )  # fmt: skip
    add_recording_options(parser)
    parser.add_argument("--force", action="store_true", help="replace an existing dataset")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import time
    from collections import Counter
    from pathlib import Path

    from ..files import probe_parent
    from ..realhand.recordings import check_dataset_out, read_recording, write_dataset

    start = time.perf_counter()
    if args.shape is not None and not args.shape.strip():
        raise UsageError("--shape must not be empty")
    options = recording_options(args)
    check_dataset_out(Path(args.out), args.force)  # refuse before reading gigabytes
    probe_parent(args.out, "--out")
    files, records = [], []
    for path in args.files:
        grasps = read_recording(path, shape=args.shape, **options)
        files.append({"file": str(path), "grasps": len(grasps)})
        records += [g.record for g in grasps]
    origin = {
        "source": "recorded",
        "files": files,
        "topic": args.topic,
        "marker": args.marker,
        "gap_s": options["gap_s"],
        "shape": args.shape,
        "prefix": options["prefix"],
        "calibration": options["calibration"].to_dict() if options["calibration"] else None,
    }
    doc = write_dataset(records, args.out, origin, force=args.force)
    doc["files"] = files
    doc["labels"] = dict(Counter(r.shape for r in records))
    doc["wall_time_s"] = time.perf_counter() - start
    if args.json:
        emit_json(doc)
    else:
        labels = ", ".join(f"{n} {k}" for k, n in sorted(doc["labels"].items()))
        print(f"{plural(doc['records'], 'grasp')} from {plural(len(files), 'file')} ({labels}) -> "
              f"{doc['out']}")  # fmt: skip
    return 0


def identify_recording(args: argparse.Namespace) -> int:
    """``identify --recording``: the shape of every grasp in a recording."""
    import time

    from ..learn.models import load_model
    from ..realhand.recordings import identify_grasps, read_recording

    if args.param or args.offset != "0,0,0" or args.rotation != "0":
        raise UsageError(
            "--param, --offset and --rotation describe a new grasp: not with --recording"
        )
    options = recording_options(args)
    model = load_model(args.model)
    start = time.perf_counter()
    grasps = read_recording(args.recording, **options)
    read_s = time.perf_counter() - start
    start = time.perf_counter()
    answers = identify_grasps(model, grasps)
    doc = {
        "recording": str(args.recording),
        "grasps": answers,
        "shapes": [a["shape"] for a in answers],
        "read_time_s": read_s,
        "identify_time_s": time.perf_counter() - start,
    }
    doc["tally"] = recording_tally(answers)
    if len(answers) == 1:  # the one-grasp contract of `identify --json`
        doc["shape"], doc["probabilities"] = answers[0]["shape"], answers[0]["probabilities"]
        doc["margin"], doc["ambiguous"] = answers[0]["margin"], answers[0]["ambiguous"]
    if args.json:
        emit_json(doc)
        return 0
    for a in answers:
        best = a["probabilities"].get(a["shape"], 1.0)
        label = f" (labelled {a['label']})" if a["label"] else ""
        doubt = (f" - AMBIGUOUS: {a['ambiguous'][0]} or {a['ambiguous'][1]}"
                 if a.get("ambiguous") else "")  # fmt: skip
        print(f"grasp {a['index'] + 1} at {a['start_s']:.2f}-{a['end_s']:.2f} s: "
              f"{a['shape']} p={best:.3f}{doubt}{label}")  # fmt: skip
    print(tally_line(doc["tally"]))
    from ..learn.doubt import batch_warning

    warning = batch_warning(doc["tally"]["ambiguous"], doc["tally"]["grasps"])
    if warning:
        print(warning)
    return 0


def recording_tally(answers: list[dict]) -> dict:
    """How a recording's grasps were named (docs/json.md ``tally``): ``{"grasps",
    "shapes": {shape: n}, "labelled", "correct", "ambiguous"}``; ``correct`` counts the
    labelled grasps named as labelled (None when no grasp carries a label), ``ambiguous`` the
    answers flagged (docs/doubt.md)."""
    from collections import Counter

    labelled = [a for a in answers if a["label"]]
    return {
        "grasps": len(answers),
        "shapes": dict(Counter(str(a["shape"]) for a in answers).most_common()),
        "labelled": len(labelled),
        "correct": sum(a["shape"] == a["label"] for a in labelled) if labelled else None,
        "ambiguous": sum(a.get("ambiguous") is not None for a in answers),
    }


def tally_line(tally: dict) -> str:
    """``5 grasps: cylinder 3, sphere 2; 1 ambiguous; 4 of 5 labelled grasps named as
    labelled``."""
    shapes = ", ".join(f"{name} {n}" for name, n in tally["shapes"].items()) or "none"
    line = f"{plural(tally['grasps'], 'grasp')}: {shapes}"
    if tally.get("ambiguous"):
        line += f"; {tally['ambiguous']} ambiguous"
    if tally["labelled"]:
        line += (f"; {tally['correct']} of {plural(tally['labelled'], 'labelled grasp')} "
                 "named as labelled")  # fmt: skip
    return line
