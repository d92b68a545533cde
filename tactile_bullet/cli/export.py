"""``tactile-bullet export``: simulated grasps as a real hand publishes them (bag or CSV)."""

from __future__ import annotations

import argparse

from ..console import plural
from ..errors import UsageError
from .common import emit_json

FORMATS = ("bag", "db3", "mcap", "csv")


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "export",
        help="write grasps as joint-state recordings (ROS 1/ROS 2 bag, CSV)",
        description="Write every grasp of a dataset as a real Shadow hand publishes it: one "
        "sensor_msgs/JointState per sample (prefixed names, positions, efforts), grasps a "
        "second apart and framed by start/end markers, so ROS tools can replay them and "
        "`import` / `identify --recording` read them back.",
    )
    parser.add_argument("--data", required=True, metavar="DIR", help="dataset folder or .npz")
    parser.add_argument(
        "--format", required=True, choices=FORMATS,
        help="bag: ROS 1 file; db3, mcap: ROS 2 bag folder; csv: one table",
    )  # fmt: skip
    parser.add_argument("--out", required=True, metavar="PATH", help="file or bag folder")
    parser.add_argument(
        "--topic", default="/joint_states",
        help="JointState topic (default /joint_states)",
    )
    parser.add_argument("--prefix", default="rh_", help="joint name prefix (default rh_)")
    parser.add_argument(
        "--coupled", action="store_true",
        help="publish FFJ0 = FFJ1 + FFJ2 (and MF, RF, LF) instead of J1 and J2",
    )  # fmt: skip
    parser.add_argument("--force", action="store_true", help="replace an existing output")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import time
    from pathlib import Path

    from ..experiments.training import records_from
    from ..realhand.export import check_out, export

    start = time.perf_counter()
    if args.format == "csv" and args.topic != "/joint_states":
        raise UsageError("--topic names a bag's JointState topic: a csv table has none")
    check_out(Path(args.out), args.format, args.force)  # before loading the dataset
    records = records_from(args.data)
    doc = export(
        records, args.out, args.format, topic=args.topic, prefix=args.prefix,
        coupled=args.coupled, force=args.force,
    )  # fmt: skip
    doc["wall_time_s"] = time.perf_counter() - start
    if args.json:
        emit_json(doc)
    else:
        print(f"wrote {plural(doc['grasps'], 'grasp')} ({plural(doc['messages'], 'joint state')}) "
              f"to {doc['out']}")  # fmt: skip
    return 0
