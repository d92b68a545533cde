"""``tactile-bullet generate``: simulate a sweep of grasps into a dataset directory."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..console import plural
from ..errors import UsageError
from .common import (
    MAX_WORKERS,
    add_engine_flag,
    count,
    emit_json,
    engine_settings,
    seed_number,
    show_progress,
)

MAX_SHARD_SIZE = 4096
"""A shard's records wait in memory until its block is whole: bounded, so a typo cannot
hold a whole dataset in memory."""


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "generate",
        help="simulate a sweep of grasps into a dataset (manifest + shards)",
        description="Simulate shapes x sizes x positions x rotations into a dataset directory. "
        "Shards are written atomically; a killed run is finished with --resume. A sweep may "
        "hold at most 1,000,000 grasps.",
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--preset", help="a built-in sweep: tour, thesis, modified, sequential, temporal, "
        "randomized or smoke (each one's size and time at the end of this help)"
    )
    source.add_argument("--config", metavar="FILE.toml", help="a sweep declared in TOML")
    parser.add_argument(
        "--scale", choices=("full", "small"), default="full",
        help="a preset as declared (full, the default) or tour-sized (small: the same recipe "
        "on tens of grasps, e.g. randomized 39 instead of 1,143; sizes below)",
    )  # fmt: skip
    parser.add_argument("--out", required=True, help="dataset directory (new or resumed)")
    parser.add_argument(
        "--workers", type=count(0, MAX_WORKERS), default=1,
        help="local worker processes, 0: in this process (default 1)",
    )  # fmt: skip
    parser.add_argument("--cluster", metavar="ADDRESS", help="Dask scheduler, e.g. tcp://h:8786")
    parser.add_argument("--resume", action="store_true", help="finish an interrupted run")
    parser.add_argument(
        "--seed", type=seed_number, default=0,
        help="seed of a random sweep's draws and of each grasp's record, 0 to 2^32-1 (default 0)",
    )  # fmt: skip
    parser.add_argument(
        "--shard-size", type=count(1, MAX_SHARD_SIZE), default=None,
        help="grasps per shard (default 32; on --resume, the dataset's own)",
    )  # fmt: skip
    add_engine_flag(parser, hand_model=True)
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)
    plain = parser.format_help

    def format_help() -> str:  # the presets' sizes are computed, only when help is asked
        from ..datasets.presets import preset_help

        return plain().rstrip("\n") + "\n\npresets: " + preset_help() + "\n"

    parser.format_help = format_help


def run(args: argparse.Namespace) -> int:

    from ..datasets.generate import generate
    from ..datasets.presets import preset
    from ..datasets.sweep_engines import with_engine
    from ..datasets.sweeps import Sweep

    settings = engine_settings(args)
    engine = settings.get("engine", "bullet")
    if args.config and args.scale != "full":
        raise UsageError("--scale applies to a --preset (a --config sweep is as it declares)")
    if args.preset:
        sweep = preset(args.preset, engine, args.scale)
    else:
        sweep = Sweep.from_toml(args.config)
    if settings:
        sweep = with_engine(sweep, **settings)
    if args.cluster and args.workers != 1:
        raise UsageError("--workers applies to local runs; a cluster has its own workers")
    # progress: a bar on a terminal, else plain lines (console.reporting, per grasp)
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
            f"{plural(doc['records'], 'grasp')} in {plural(doc['shards'], 'shard')} at "
            f"{doc['out']} "
            f"({doc['failed']} failed) in {doc['wall_time_s']:.1f} s"
        )
        for problem in doc["repaired"]:
            print(f"simulated again: {problem['file']} ({problem['problem']})")
        for line in failure_lines(doc["out"]):
            print(line)
    return 0


def failure_lines(out: str, shown: int = 3) -> list[str]:
    """Why grasps failed, on the terminal and not only in manifest.json: each distinct reason
    once, with how many grasps and which tasks (the first ``shown`` reasons)."""
    from ..datasets.integrity import read_manifest
    from ..errors import UsageError

    try:
        failed = read_manifest(Path(out))["failed"]
    except (UsageError, KeyError, TypeError):
        return []
    reasons: dict[str, list[int]] = {}
    for entry in failed:
        reasons.setdefault(str(entry.get("error")), []).append(int(entry.get("task", -1)))
    lines = []
    for reason, tasks in list(reasons.items())[:shown]:
        which = ", ".join(str(t) for t in tasks[:5]) + (", ..." if len(tasks) > 5 else "")
        lines.append(f"failed: {plural(len(tasks), 'grasp')} (task {which}): {reason}")
    if len(reasons) > shown:
        where = Path(out) / "manifest.json"
        lines.append(f"failed: {len(reasons) - shown} more reasons in {where}")
    return lines
