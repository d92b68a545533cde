"""``tactile-bullet plugins``: what each plugin registered, built-in ones included."""

from __future__ import annotations

import argparse

from .common import emit_json


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "plugins",
        help="list the plugins and the descriptors, classifiers and shapes each registered",
        description="List the installed plugins (the built-ins and third-party packages), what "
        "each registered (descriptors, classifiers, shapes), and any that failed to load. "
        "TACTILE_BULLET_PLUGINS and TACTILE_BULLET_BLOCK_PLUGINS choose which load.",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..plugins import KINDS, plugin_report

    report = plugin_report()
    if args.json:
        emit_json(report)
        return 0
    for entry in report:
        tag = " (built-in)" if entry.get("builtin") else ""
        print(f"{entry['name']} {entry.get('version') or ''}{tag}".rstrip())
        if "error" in entry:
            print(f"    skipped: {entry['error']}")
            continue
        for kind in KINDS:
            if entry[kind]:
                print(f"    {kind}: {', '.join(entry[kind])}")
    return 0
