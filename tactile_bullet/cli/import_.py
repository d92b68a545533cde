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
        "--shape", metavar="NAME", action="append",
        help="label grasps with this shape (recordings of a known object): once, every file; "
        "once per file, the files in order (import cone.bag ball.bag --shape cone --shape "
        "sphere)",
    )  # fmt: skip
    parser.add_argument(
        "--labels", metavar="FILE.csv",
        help="a CSV of labels: rows 'recording,shape' (every grasp of that recording) or "
        "'recording,grasp,shape' (grasp: its index in the recording from 0, as identify "
        "--recording numbers them); a recording is named by its path as given or its file "
        "name; grasps it does not name stay unlabelled",
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
    shapes = file_shapes(args.files, args.shape, args.labels)
    options = recording_options(args, args.files)
    check_dataset_out(Path(args.out), args.force)  # refuse before reading gigabytes
    probe_parent(args.out, "--out")
    files, records = [], []
    from ..console import tick

    for done, path in enumerate(args.files):
        tick("import: recordings read", done, len(args.files))
        grasps = read_recording(path, shape=shapes[done].get(None), **options)
        files.append({"file": str(path), "grasps": len(grasps)})
        records += [relabelled(g, shapes[done]) for g in grasps]
        beyond = [k for k in shapes[done] if k is not None and k >= len(grasps)]
        if beyond:
            held = plural(len(grasps), "grasp")
            raise UsageError(f"--labels names {path} grasp {beyond[0]}, which the recording "
                             f"does not hold ({held}, numbered from 0)")  # fmt: skip
    tick("import: recordings read", len(args.files), len(args.files))
    origin = {
        "source": "recorded",
        "files": files,
        "topic": args.topic,
        "marker": args.marker,
        "gap_s": options["gap_s"],
        "shape": args.shape[0] if args.shape and len(args.shape) == 1 else None,
        "shapes": args.shape if args.shape and len(args.shape) > 1 else None,
        "labels": str(args.labels) if args.labels else None,
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


def file_shapes(
    files: list[str], shape: list[str] | None, labels: str | None
) -> list[dict[int | None, str]]:
    """Each file's labels, before any recording is read: ``{None: shape}`` labels every grasp
    of the file, ``{k: shape}`` its grasp ``k``; from ``--shape`` (once: every file; once per
    file: in order) or a ``--labels`` CSV. Every problem is a UsageError."""
    _check_distinct(files)
    out = _file_shapes(files, shape, labels)
    _check_labels({label for by in out for label in by.values()})
    return out


def _check_distinct(files: list[str]) -> None:
    """A UsageError where one recording is given twice (under any two paths): its grasps
    would be counted twice, or labelled two ways."""
    import os

    seen: dict[str, str] = {}
    for f in files:
        key = os.path.realpath(f)
        if key in seen:
            raise UsageError(f"{f} is given twice (as {seen[key]} and {f}): give each "
                             "recording once")  # fmt: skip
        seen[key] = f


def _check_labels(labels: set[str]) -> None:
    """A UsageError where a label differs from a known shape's name by case only (a typo that
    would make a class of its own); any other name is the user's own class (a mesh's object,
    say), as simulated object sets label theirs."""
    from ..plugins import shape_names

    known = {n.lower(): n for n in shape_names()}
    for label in sorted(labels):
        if label not in known.values() and label.lower() in known:
            raise UsageError(f"label {label!r} is not a shape name (names are case-sensitive): "
                             f"did you mean {known[label.lower()]!r}?")  # fmt: skip


def _file_shapes(
    files: list[str], shape: list[str] | None, labels: str | None
) -> list[dict[int | None, str]]:
    out: list[dict[int | None, str]] = [{} for _ in files]
    if shape and labels:
        raise UsageError("--shape and --labels both label the grasps: give one")
    for name in shape or ():
        if not name.strip():
            raise UsageError("--shape must not be empty")
    if shape:
        if len(shape) == 1:
            return [{None: shape[0].strip()} for _ in files]
        if len(shape) != len(files):
            raise UsageError(f"--shape is given {len(shape)} times for {len(files)} files: "
                             "give it once (every file) or once per file, in the files' order")
        return [{None: s.strip()} for s in shape]
    if labels:
        return _read_labels(labels, files)
    return out


def _read_labels(labels: str, files: list[str]) -> list[dict[int | None, str]]:
    import csv
    from pathlib import Path

    from ..files import input_path

    path = input_path(labels, "labels file", limit=64 << 20)
    out: list[dict[int | None, str]] = [{} for _ in files]
    by_path = {str(f): i for i, f in enumerate(files)}
    by_name: dict[str, list[int]] = {}
    for i, f in enumerate(files):
        by_name.setdefault(Path(f).name, []).append(i)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"--labels {path}: cannot read it ({exc})") from None
    rows = [r for r in csv.reader(text.splitlines()) if r and any(c.strip() for c in r)]
    if rows and [c.strip().lower() for c in rows[0]] in (["recording", "shape"],
                                                          ["recording", "grasp", "shape"]):
        rows = rows[1:]  # a header
    if not rows:
        raise UsageError(f"--labels {path}: no rows (recording,shape or recording,grasp,shape)")
    for line, row in enumerate(rows, 1):
        row = [c.strip() for c in row]
        where = f"--labels {path}, row {line}"
        if len(row) not in (2, 3) or not all(row):
            raise UsageError(f"{where}: expected 'recording,shape' or 'recording,grasp,shape', "
                             f"got {','.join(row)!r}")  # fmt: skip
        name, shape = row[0], row[-1]
        if name in by_path:
            index = by_path[name]
        elif len(by_name.get(Path(name).name, [])) == 1 and Path(name).name == name:
            index = by_name[name][0]
        elif len(by_name.get(name, [])) > 1:
            raise UsageError(f"{where}: {name!r} is the name of several recordings given; "
                             "name it by its path")  # fmt: skip
        else:
            raise UsageError(f"{where}: {name!r} is not one of the recordings given")
        grasp: int | None = None
        if len(row) == 3:
            try:
                grasp = int(row[1])
            except ValueError:
                grasp = -1
            if grasp < 0:
                raise UsageError(f"{where}: grasp must be an index from 0, got {row[1]!r}")
        if grasp in out[index] and out[index][grasp] != shape:
            which = f"{name} grasp {grasp}" if grasp is not None else name
            raise UsageError(f"{where}: {which} is labelled twice "
                             f"({out[index][grasp]!r} and {shape!r})")
        out[index][grasp] = shape
    return out


def relabelled(grasp, by: dict[int | None, str]):
    """The grasp's record, its shape from ``by`` (its own index first, then the file's)."""
    from dataclasses import replace

    shape = by.get(grasp.index)
    if shape is None or shape == grasp.record.shape:
        return grasp.record
    return replace(grasp.record, shape=shape)
