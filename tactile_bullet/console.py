"""What a person sees while work runs: one JSON document on stdout, progress on stderr.

Shared by the CLI and the library's long loops (``experiments.workflow``, ``datasets``), so it
lives below both. Progress goes to stderr only, so ``--json`` output on stdout stays one
document.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterable
from typing import Any


def emit_json(doc: Any) -> None:
    """Print one JSON document on stdout (the ``--json`` contract)."""
    from .files import json_value

    json.dump(doc, sys.stdout, indent=2, default=json_value)
    sys.stdout.write("\n")


def show_progress(json_mode: bool) -> bool:
    """Progress bars only for a person watching: a TTY on stderr and no --json."""
    return not json_mode and sys.stderr.isatty()


def log_lines(json_mode: bool) -> bool:
    """Plain progress lines on stderr: for a person at a terminal (no --json), and wherever
    stderr is not a terminal (a log file, CI), so long work is never silent for minutes.
    Only --json at a terminal stays quiet (docs/json.md)."""
    return not json_mode or not sys.stderr.isatty()


def progress(iterable: Iterable, total: int | None, desc: str, enabled: bool) -> Iterable:
    if not enabled:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, unit="grasp", file=sys.stderr)


def plural(n: int, noun: str, plural: str | None = None) -> str:
    """``"1 shard"``, ``"3 shards"``: a number with its noun in the right number (``plural``
    where adding "s" is wrong, e.g. ``plural(n, "class", "classes")``)."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"
