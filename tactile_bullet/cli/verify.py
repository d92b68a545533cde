"""``tactile-bullet verify``: check a dataset (or record files) before trusting it."""

from __future__ import annotations

import argparse

from ..console import plural
from .common import emit_json


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "verify",
        help="check a dataset: manifest, every shard's checksum and record count",
        description="Check a dataset folder: the manifest (format, fields, each block listed "
        "once, counts that add up, shard names inside the folder) and every shard (present, "
        "size, sha256, record count); or check that every record of a folder of .npz records "
        "(or one record file) can be read. Exit status 0 when sound, 2 naming each problem.",
    )
    parser.add_argument("--data", required=True, metavar="DIR", help="dataset folder or .npz")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import sys

    from ..datasets.dataset import verify

    doc = verify(args.data)
    if args.json:
        emit_json(doc)
    else:
        print(verify_text(doc), end="")
    if not doc["ok"]:
        n = len(doc["problems"])
        print(
            f"tactile-bullet verify: error: {args.data} has {n} problem{'s' * (n > 1)}",
            file=sys.stderr,
        )
        return 2
    return 0


def verify_text(doc: dict) -> str:
    """What ``verify`` prints: a summary line, then one line per problem."""
    if doc["kind"] == "records":
        n = doc["records"]
        head = f"{doc['data']}: {n} readable grasp record{'s' * (n != 1)}"
    elif "listed_records" in doc:
        head = (
            f"{doc['data']}: {doc['records']} of {plural(doc['listed_records'], 'record')} "
            f"readable, {plural(doc['shards'], 'shard')} listed for {plural(doc['tasks'], 'task')} "
            f"({plural(doc['failed'], 'task')} the simulator could not run)"
        )
    else:
        head = f"{doc['data']}: the manifest cannot be read"
    lines = [f"{head}: {'sound' if doc['ok'] else 'DAMAGED'}"]
    if len(doc.get("engines", ())) > 1:
        lines.append(f"  mixes physics engines: {', '.join(doc['engines'])}")
    for p in doc["problems"]:
        lost = f" ({plural(p['records'], 'record')})" if p["records"] else ""
        lines.append(f"  {p['file']}: {p['problem']}{lost}")
    return "\n".join(lines) + "\n"
