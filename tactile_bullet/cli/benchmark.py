"""``tactile-bullet benchmark``: rank descriptor x classifier pairs on out-of-distribution
protocols (unseen sizes and poses, sensor noise, simulator shift)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import UsageError
from .common import (
    MAX_WORKERS,
    add_engine_flag,
    count,
    emit_json,
    engine_name,
    log_lines,
    seed_number,
    show_progress,
)


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "benchmark",
        help="rank descriptors x classifiers on in- and out-of-distribution protocols",
        description="Simulate the protocols' grasp sets (cached under --out, resumable), fit "
        "every descriptor x classifier pair clean and noise-aware, and score it on every "
        "protocol level. Writes benchmark.json, table.txt, noise.png and shift.png.",
    )
    parser.add_argument(
        "--protocol", metavar="NAME,...", default="all",
        help="in-distribution, unseen-sizes, unseen-poses, sensor-noise, sim-shift, "
        "coupling-shift, or all (those six, the default); cross-engine and mixed-engine "
        "(bullet and mujoco) when named; robustness alone: every candidate method on every "
        "hand and condition, scored by its worst column (docs/robustness.md); active alone: "
        "accuracy after 1, 2, 3 grasps with the next pose planned, random or repeated "
        "(docs/exploration.md)",
    )  # fmt: skip
    parser.add_argument(
        "--other-hand", action="append", metavar="NAME=FILE",
        help="robustness: a hand written by others as a column (menagerie=FILE, "
        "gymnasium=FILE: a model `convert-hand` wrote; repeatable or comma-separated)",
    )  # fmt: skip
    parser.add_argument("--descriptor", metavar="A,B", action="append",
                        help="descriptors (repeatable; default: all installed)")  # fmt: skip
    parser.add_argument("--classifier", metavar="X,Y", action="append",
                        help="classifiers (repeatable; default: all installed)")  # fmt: skip
    parser.add_argument(
        "--training", metavar="T,...", default="clean,noise-aware",
        help="clean, noise-aware and/or randomized (default: clean,noise-aware; randomized "
        "simulates each training set once more with the hand drawn per grasp)",
    )  # fmt: skip
    parser.add_argument("--out", required=True, metavar="DIR", help="results and grasp cache")
    parser.add_argument(
        "--cache", metavar="DIR", help="where simulated sets live (default: OUT/data)"
    )
    parser.add_argument(
        "--quick", action="store_true",
        help="small sets, headline levels, svm and knn on the cheap descriptors (~2 min); "
        "the same as --scale quick",
    )  # fmt: skip
    parser.add_argument(
        "--scale", choices=("full", "quick", "tiny"),
        help="set sizes: full (24/12 grasps per shape), quick (8/4), tiny (5/2, the pytest "
        "comparison suite's)",
    )  # fmt: skip
    parser.add_argument(
        "--workers", type=count(1, MAX_WORKERS), default=2, help="simulation processes (default 2)"
    )
    parser.add_argument("--seed", type=seed_number, default=0, help="seed of the perturbations")
    parser.add_argument(
        "--replicate", type=count(0, 99), default=0, metavar="K",
        help="robustness: draw every test set afresh (seeds + 1000 K; training sets kept), "
        "for a recipe chosen after seeing the first sets (docs/robustness.md)",
    )  # fmt: skip
    add_engine_flag(parser)
    parser.add_argument("--json", action="store_true", help="print the rows as one JSON list")
    from .common import add_hand_calibration_flag

    add_hand_calibration_flag(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..experiments.benchmark import default_classifiers, default_descriptors, run_benchmark
    from .compare import name_list

    if args.cache is not None and Path(args.cache).exists() and not Path(args.cache).is_dir():
        raise UsageError(f"--cache {args.cache} exists and is not a folder")
    if "robustness" in [p.strip() for p in str(args.protocol).split(",")]:
        return run_robustness(args)
    if args.replicate:
        raise UsageError("--replicate draws the test sets of --protocol robustness afresh; "
                         "other protocols do not read it")  # fmt: skip
    if "active" in [p.strip() for p in str(args.protocol).split(",")]:
        return run_active(args)
    if args.other_hand:
        raise UsageError("--other-hand adds a column to --protocol robustness or active")

    if args.scale and args.quick and args.scale != "quick":
        raise UsageError(f"--quick contradicts --scale {args.scale}")
    scale = args.scale or ("quick" if args.quick else "full")
    engine = engine_name(args) or "bullet"
    from ..experiments.protocols import ENGINE_PROTOCOLS, resolve

    if any(p in ENGINE_PROTOCOLS for p in resolve(args.protocol, engine)):
        engine_name(argparse.Namespace(engine="mujoco"))  # both engines must be installed
    descriptors = name_list(args.descriptor, "--descriptor", lambda: default_descriptors(scale))
    classifiers = name_list(args.classifier, "--classifier", lambda: default_classifiers(scale))
    trainings = name_list(args.training, "--training", lambda: ())
    show = show_progress(args.json)
    # plain lines also where stderr is no terminal (a log file, CI): minutes of silence otherwise
    log = (lambda msg: print(msg, file=sys.stderr, flush=True)) if log_lines(args.json) else None
    doc = run_benchmark(
        args.out, args.protocol, descriptors, classifiers, trainings,
        quick=scale, workers=args.workers, seed=args.seed, cache=args.cache,
        show=show, log=log, engine=engine,
    )  # fmt: skip
    if args.json:
        emit_json(doc["rows"])
        return 0
    from ..experiments.benchmark import headline_table

    print("headline accuracy (%) per protocol, best worst-case first")
    print(headline_table(doc["rows"]), end="")
    print(f"results: {args.out}/benchmark.json, figures: {', '.join(doc['figures']) or 'none'}")
    print(f"wall time: {doc['wall_time_s']:.0f} s")
    return 0


def run_robustness(args: argparse.Namespace) -> int:
    """``benchmark --protocol robustness``: the matrix of docs/robustness.md."""
    from ..experiments import robustness as R

    if args.protocol.strip() != "robustness":
        raise UsageError("--protocol robustness runs alone (it has its own sets and columns)")
    if args.scale and args.quick and args.scale != "quick":
        raise UsageError(f"--quick contradicts --scale {args.scale}")
    for flag in ("engine", "hand_calibration"):
        if getattr(args, flag, None):
            raise UsageError(f"--{flag.replace('_', '-')} is not read by --protocol robustness: "
                             "its columns name their own hands")  # fmt: skip
    if args.training != "clean,noise-aware":
        raise UsageError("--training is not read by --protocol robustness: every method is "
                         "tried with each training it supports")  # fmt: skip
    scale = args.scale or ("quick" if args.quick else "full")
    hands = R.parse_hands(args.other_hand)
    candidates = R.select_candidates(args.descriptor, args.classifier)
    log = (lambda msg: print(msg, file=sys.stderr, flush=True)) if log_lines(args.json) else None
    doc = R.run_robustness(args.out, scale=scale, workers=args.workers, seed=args.seed,
                           cache=args.cache, hands=hands, candidates=candidates,
                           show=show_progress(args.json), log=log,
                           replicate=args.replicate)  # fmt: skip
    if args.json:
        emit_json(doc)
        return 0
    print((Path(args.out) / "table.md").read_text(), end="")
    for column, why in doc["not_run"].items():
        print(f"{column}: not run ({why})")
    best = doc["default"]
    if best is None:
        print("no eligible method (docs/robustness.md, rule 3)")
    else:
        print(f"winner by the declared rule: {best['method']} ({best['training']}), worst "
              f"column {100 * best['score']:.1f}%, mean {100 * best['mean']:.1f}%")  # fmt: skip
    print(f"results: {args.out}/robustness.json, {args.out}/table.md; "
          f"wall time {doc['wall_time_s']:.0f} s")  # fmt: skip
    return 0


def run_active(args: argparse.Namespace) -> int:
    """``benchmark --protocol active``: the second grasp's worth (docs/exploration.md)."""
    from ..experiments.active import run_active as active
    from ..experiments.robustness import parse_hands

    if args.protocol.strip() != "active":
        raise UsageError("--protocol active runs alone (it has its own objects and columns)")
    if args.scale and args.quick and args.scale != "quick":
        raise UsageError(f"--quick contradicts --scale {args.scale}")
    scale = args.scale or ("quick" if args.quick else "full")
    hands = parse_hands(args.other_hand)
    log = (lambda msg: print(msg, file=sys.stderr, flush=True)) if log_lines(args.json) else None
    doc = active(args.out, scale=scale, hands=hands, seed=args.seed, log=log)
    if args.json:
        emit_json(doc)
        return 0
    print((Path(args.out) / "table.md").read_text(), end="")
    d = doc["decision_s"]
    if d["decisions"]:
        print(f"a planned next pose took {d['median']:.2f} s (median; at most {d['max']:.2f} s) "
              f"over {d['decisions']} decisions")  # fmt: skip
    print(f"results: {args.out}/active.json; wall time {doc['wall_time_s']:.0f} s")
    return 0
