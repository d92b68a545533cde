"""``tactile-bullet make-objects``: write the example household objects and their sweeps."""

from __future__ import annotations

import argparse

from .common import add_force_flag, emit_json


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "make-objects",
        help="write the example object meshes and their train/test sweeps",
        description="Write fourteen household-like objects (bottle, can, ball, ...) as mesh "
        "files in mixed formats and units, and train.toml / test.toml sweeps over them for "
        "`generate --config`. Nothing is downloaded; the same command writes the same files.",
    )
    parser.add_argument("--out", required=True, metavar="DIR", help="folder to write into")
    parser.add_argument(
        "--only", metavar="A,B", help="comma-separated object names (default: all fourteen)"
    )
    add_force_flag(parser, "object and sweep files in --out")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..objects.examples import check_names, write_set

    names = [n.strip() for n in args.only.split(",")] if args.only else None
    names = check_names(names)
    paths = write_set(args.out, names, args.force)
    if args.json:
        emit_json({"out": str(args.out), "objects": names, "files": [str(p) for p in paths]})
    else:
        for path in paths:
            print(path)
    return 0
