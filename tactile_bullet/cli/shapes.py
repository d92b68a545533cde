"""``tactile-bullet shapes``: the registered shapes, their parameters and valid ranges."""

from __future__ import annotations

import argparse

from .common import emit_json


def add_parser(sub) -> None:
    parser = sub.add_parser("shapes", help="list the shapes and their size parameters")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def _all_shapes():
    from ..plugins import get_shape, shape_names

    return [get_shape(n) for n in shape_names()]


def run(args: argparse.Namespace) -> int:
    shapes = _all_shapes()
    if args.json:
        emit_json([s.describe() for s in shapes])
        return 0
    for shape in shapes:
        tag = "" if shape.thesis else "  (modified shape)"
        print(f"{shape.name}{tag}: {shape.doc}")
        for key, p in shape.params.items():
            print(f"    {key:<14} default {p.default:<7g} range [{p.min:g}, {p.max:g}] {p.unit}")
    return 0
