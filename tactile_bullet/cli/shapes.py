"""``tactile-bullet shapes``: the registered shapes, their parameters and valid ranges."""

from __future__ import annotations

import argparse

from .common import emit_json


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "shapes",
        help="list the shapes and their size parameters",
        description="List every installed shape (built-in and plugins'), its size parameters "
        "in metres with their valid ranges, and where identification without training holds.",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def _all_shapes():
    from ..plugins import get_shape, shape_names

    return [get_shape(n) for n in shape_names()]


def _entry(shape, ranges: dict) -> dict:
    """``describe()`` plus, per parameter, where training-free identification holds."""
    doc = shape.describe()
    for key, (lo, hi) in ranges.get(shape.name, {}).items():
        doc["params"][key]["identification_range"] = [lo, hi]
    return doc


def run(args: argparse.Namespace) -> int:
    from ..perception.patterns import identification_ranges

    ranges = identification_ranges()
    docs = [_entry(s, ranges) for s in _all_shapes()]
    if args.json:
        emit_json(docs)
        return 0
    for doc in docs:
        tag = "" if doc["thesis"] else "  (modified shape)"
        print(f"{doc['name']}{tag}: {doc['doc']}")
        for key, p in doc["params"].items():
            note = _held_note(p.get("identification_range"))
            print(
                f"    {key:<14} default {p['default']:<7g} range [{p['min']:g}, {p['max']:g}] "
                f"{p['unit']}{note}"
            )
    return 0


def _held_note(held: list[float] | None) -> str:
    """Where training-free identification held: a range, or the one size tested where it
    held alone (a ``[0.035, 0.035]`` "range" reads as a bug)."""
    if not held:
        return ""
    if held[0] == held[1]:
        return f"  identified without training only at {held[0]:g}"
    return f"  identified without training in [{held[0]:g}, {held[1]:g}]"
