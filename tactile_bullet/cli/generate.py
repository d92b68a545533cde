"""``tactile-bullet generate``: simulate a sweep of grasps into a dataset directory."""

from __future__ import annotations

import argparse

from ..errors import UsageError
from .common import emit_json, show_progress


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "generate",
        help="simulate a sweep of grasps into a dataset (manifest + shards)",
        description="Simulate shapes x sizes x positions x rotations into a dataset directory. "
        "Shards are written atomically; a killed run is finished with --resume.",
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--preset", help="thesis, modified, sequential, temporal or smoke (a few grasps, seconds)"
    )
    source.add_argument("--config", metavar="FILE.toml", help="a sweep declared in TOML")
    parser.add_argument("--out", required=True, help="dataset directory (new or resumed)")
    parser.add_argument("--workers", type=int, default=1, help="local worker processes")
    parser.add_argument("--cluster", metavar="ADDRESS", help="Dask scheduler, e.g. tcp://h:8786")
    parser.add_argument("--resume", action="store_true", help="finish an interrupted run")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--shard-size", type=int, default=None,
        help="grasps per shard (default 32; on --resume, the dataset's own)",
    )  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..dataset import generate
    from ..sweeps import Sweep, preset

    sweep = preset(args.preset) if args.preset else Sweep.from_toml(args.config)
    if args.cluster and args.workers != 1:
        raise UsageError("--workers applies to local runs; a cluster has its own workers")
    doc = generate(
        sweep,
        args.out,
        workers=args.workers,
        cluster=args.cluster,
        resume=args.resume,
        seed=args.seed,
        shard_size=args.shard_size,
        progress=show_progress(args.json),
    )
    if args.json:
        emit_json(doc)
    else:
        print(
            f"{doc['records']} grasps in {doc['shards']} shards at {doc['out']} "
            f"({doc['failed']} failed) in {doc['wall_time_s']:.1f} s"
        )
    return 0
