"""Reading grasp data from the command line: ``--allow-partial`` and what it skipped.

Every command that reads a dataset refuses damaged data (exit status 2 naming the shard);
``--allow-partial`` reads the rest, and the command then says how many records it skipped:
a line on stdout, or ``data_skipped`` in its ``--json`` document.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Mapping, MutableMapping, Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # numpy and the dataset module load only when a command runs
    from ..datasets.dataset import LoadedRecords


def add_allow_partial(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--allow-partial",
        action="store_true",
        help="read a damaged or unfinished dataset anyway: skip what is damaged and say how "
        "many records were skipped (refused otherwise)",
    )


def read_data(
    path: str | os.PathLike, args: argparse.Namespace, full: bool = True
) -> LoadedRecords:
    """The records at ``path`` (dataset, folder of records or one record file), honouring
    ``args.allow_partial``."""
    from ..datasets.dataset import read_records

    return read_records(path, getattr(args, "allow_partial", False), full=full)


def report_skipped(
    loaded: LoadedRecords | Sequence[LoadedRecords],
    args: argparse.Namespace,
    docs: MutableMapping[str, Any] | Sequence[MutableMapping[str, Any]] = (),
) -> None:
    """With ``--allow-partial``: ``data_skipped`` in each JSON document in ``docs`` (also
    when nothing was skipped, so scripts can rely on it), or a line of text when something
    was."""
    from ..datasets.dataset import LoadedRecords

    if not getattr(args, "allow_partial", False):
        return
    parts = [loaded] if isinstance(loaded, LoadedRecords) else list(loaded)
    merged = LoadedRecords([], [p for part in parts for p in part.problems])
    if getattr(args, "json", False):
        for doc in [docs] if isinstance(docs, Mapping) else docs:
            doc["data_skipped"] = merged.as_json()
    elif merged.problems:
        print(merged.summary())
