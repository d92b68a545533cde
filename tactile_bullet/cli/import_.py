"""``tactile-bullet import``: real-hand recordings (ROS bags, CSV, Parquet) into a dataset."""

from __future__ import annotations

import argparse

from ..console import plural
from ..errors import UsageError
from .common import emit_json
from .recording_args import add_recording_options, recording_options


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
    from ..console import tick

    for done, path in enumerate(args.files):
        tick("import: recordings read", done, len(args.files))
        grasps = read_recording(path, shape=args.shape, **options)
        files.append({"file": str(path), "grasps": len(grasps)})
        records += [g.record for g in grasps]
    tick("import: recordings read", len(args.files), len(args.files))
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
