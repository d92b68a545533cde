"""Options shared by every command that reads recordings (``import``, ``identify
--recording``): the topic, the grasp marker, the silence that ends a grasp, a calibration and the
hand's prefix."""

from __future__ import annotations

import argparse

from ..errors import UsageError
from .common import parse_number


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


TABLE_SUFFIXES = (".csv", ".parquet", ".pq")
"""Recordings that are one table, with no topics (``recordings.read_samples``)."""


def recording_options(args: argparse.Namespace, files=()) -> dict:
    """The keyword arguments of ``recordings.read_recording`` from the shared options;
    ``files``, the recordings they will read: a ``--topic`` where every one is a table (which
    has no topics) is refused rather than ignored."""
    from pathlib import Path

    from ..realhand.calibration import load_calibration
    from ..realhand.names import DEFAULT_TOPIC

    files = [Path(f) for f in files]
    if args.topic != DEFAULT_TOPIC and files and all(
        f.suffix.lower() in TABLE_SUFFIXES for f in files
    ):
        raise UsageError(f"--topic names a bag's JointState topic: {files[0]} is a table "
                         "(CSV or Parquet), which has none")  # fmt: skip

    gap = parse_number(args.gap, "--gap")
    if gap <= 0:
        raise UsageError(f"--gap must be positive, got {args.gap}")
    calibration = load_calibration(args.calibration) if args.calibration else None
    from ..realhand.names import prefix_option

    return {"topic": args.topic, "marker": args.marker, "gap_s": gap, "calibration": calibration,
            "prefix": prefix_option(args.prefix)}  # fmt: skip
