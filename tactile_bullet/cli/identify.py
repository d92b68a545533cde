"""``tactile-bullet identify``: name the shape of one new grasp with a saved model."""

from __future__ import annotations

import argparse
import math

from ..console import plural
from ..errors import UsageError
from .common import (
    add_engine_flag,
    emit_json,
    engine_settings,
    note_hand_calibration,
    parse_key_values,
    parse_number,
    parse_offset,
    parse_rotation,
    seed_number,
)
from .recording_args import add_recording_options, recording_options
from .shape_info import add_mesh_options, mesh_shape


def ambiguity_text(doc) -> str:
    """What the text output adds to an answer the model is unsure of (empty otherwise)."""
    pair = doc.get("ambiguous")
    if not pair:
        return ""
    margin = doc.get("margin")
    how = f" (margin {margin:.3f})" if margin is not None else ""
    return f" - AMBIGUOUS: {pair[0]} or {pair[1]}{how}"


def answer_text(doc) -> str:
    """``SHAPE`` with what the model doubts: ``unknown (best guess SHAPE)`` where no family
    it knows explains the grasp, and the ambiguity where two shapes are close."""
    if doc.get("unknown"):
        from .grasp import unknown_reason

        return f"UNKNOWN: {unknown_reason(doc)}; best guess {doc['shape']}"
    if doc.get("renamed_from"):
        from .grasp import renamed_reason

        return f"{doc['shape']} ({renamed_reason(doc)}){ambiguity_text(doc)}"
    return f"{doc['shape']}{ambiguity_text(doc)}"


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "identify",
        help="simulate a grasp (or read a record) and name its shape with a model",
        description="Identify the shape of one grasp: simulate a new one on --shape, or read "
        "a saved GraspRecord with --record, and print the model's answer and probabilities.",
    )
    parser.add_argument(
        "--model", metavar="FILE",
        help="model file written by `train` or `adapt` (default: the built-in default "
        "identifier, the robustness matrix's winner: docs/robustness.md)",
    )  # fmt: skip
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--shape", help="simulate a grasp on this shape")
    source.add_argument("--record", metavar="REC.npz", help="a saved grasp record")
    source.add_argument(
        "--recording", metavar="FILE", help="a real hand's recording (bag, CSV, Parquet)"
    )
    source.add_argument("--mesh", metavar="FILE", help="simulate a grasp on this mesh file")
    add_mesh_options(parser)
    parser.add_argument(
        "--param", action="append", metavar="KEY=VALUE", help="shape size in metres (repeatable)"
    )
    parser.add_argument(
        "--offset", default="0,0,0", metavar="X,Y,Z",
        help="object offset in metres, palm frame as in grasp (default 0,0,0)",
    )  # fmt: skip
    parser.add_argument(
        "--rotation", default="0", metavar="DEG",
        help="object rotation about the palm normal in degrees (default 0)",
    )  # fmt: skip
    parser.add_argument(
        "--seed", type=seed_number, default=0,
        help="seed stored in the simulated record (default 0)",
    )  # fmt: skip
    add_engine_flag(parser, hand_model=True)
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    add_recording_options(parser)
    from .common import add_hand_calibration_flag

    add_hand_calibration_flag(parser)
    parser.set_defaults(run=run)


def _record(args: argparse.Namespace):
    if args.record:
        if args.param or args.offset != "0,0,0" or args.rotation != "0" or args.engine or (
            args.hand_model
        ):
            raise UsageError(
                "--param, --offset, --rotation, --engine and --hand-model describe a new grasp: "
                "not with --record"
            )
        from ..records import load_record

        return load_record(args.record)
    from ..records import ControllerSettings, Pose
    from ..sim.grasp import simulate_grasp

    params = {k: parse_number(v, f"--param {k}") for k, v in parse_key_values(args.param).items()}
    pose = Pose(parse_offset(args.offset), parse_rotation(args.rotation))
    controller = ControllerSettings(**engine_settings(args))
    return simulate_grasp(mesh_shape(args) or args.shape, params, pose, controller, seed=args.seed)


def run(args: argparse.Namespace) -> int:
    from ..experiments.training import identify
    from ..learn.default import resolve_model

    if args.recording:
        return identify_recording(args)
    if args.calibration or args.marker or args.topic != "/joint_states" or args.gap != "0.5":
        raise UsageError("--topic, --marker, --gap and --calibration read a --recording")
    model = resolve_model(args.model)
    record = _record(args)
    doc = identify(model, record)
    doc["true_shape"] = record.shape
    doc["grasp"] = {
        "shape": record.shape,
        "params": dict(record.params),
        "pose": {
            "offset": list(record.pose.offset),
            "rotation_deg": math.degrees(record.pose.rotation),
        },
        "fingers_in_contact": list(record.fingers_in_contact),
        "flags": list(record.flags),
    }
    note_hand_calibration(args, doc)
    if args.json:
        emit_json(doc)
    elif doc["shape"] is None:
        print(f"{doc['reason']} (grasped: {record.shape})")
    else:
        print(f"identified: {answer_text(doc)} (grasped: {record.shape})")
        ranked = sorted(doc["probabilities"].items(), key=lambda kv: -kv[1])
        for name, p in ranked:
            print(f"  {name:<20} {p:6.3f}")
    return 0


def identify_recording(args: argparse.Namespace) -> int:
    """``identify --recording``: the shape of every grasp in a recording."""
    import time

    from ..learn.default import resolve_model
    from ..realhand.recordings import fused_objects, identify_grasps, read_recording

    if args.param or args.offset != "0,0,0" or args.rotation != "0":
        raise UsageError(
            "--param, --offset and --rotation describe a new grasp: not with --recording"
        )
    options = recording_options(args, [args.recording])
    model = resolve_model(args.model)
    start = time.perf_counter()
    grasps = read_recording(args.recording, **options)
    read_s = time.perf_counter() - start
    start = time.perf_counter()
    answers = identify_grasps(model, grasps)
    doc = {
        "recording": str(args.recording),
        "grasps": answers,
        "shapes": [a["shape"] for a in answers],
        "read_time_s": read_s,
        "identify_time_s": time.perf_counter() - start,
    }
    doc["tally"] = recording_tally(answers)
    doc["objects"] = fused_objects(model, answers)
    if len(answers) == 1:  # the one-grasp contract of `identify --json`
        doc["shape"], doc["probabilities"] = answers[0]["shape"], answers[0]["probabilities"]
        doc["margin"], doc["ambiguous"] = answers[0]["margin"], answers[0]["ambiguous"]
        doc["unknown"] = answers[0].get("unknown", False)
    if args.json:
        emit_json(doc)
        return 0
    for a in answers:
        best = a["probabilities"].get(a["shape"], 1.0)
        label = f" (labelled {a['label']})" if a["label"] else ""
        doubt = (f" - AMBIGUOUS: {a['ambiguous'][0]} or {a['ambiguous'][1]}"
                 if a.get("ambiguous") else "")  # fmt: skip
        if a.get("unknown"):
            doubt = " - UNKNOWN: unlike every grasp the model learnt (best guess)"
        print(f"grasp {a['index'] + 1} at {a['start_s']:.2f}-{a['end_s']:.2f} s: "
              f"{a['shape']} p={best:.3f}{doubt}{label}")  # fmt: skip
    for o in doc["objects"]:
        grasps = ", ".join(str(i + 1) for i in o["grasps"])
        doubt = (" - UNKNOWN (best guess)" if o["unknown"] else
                 f" - AMBIGUOUS: {o['ambiguous'][0]} or {o['ambiguous'][1]}" if o["ambiguous"]
                 else "")  # fmt: skip
        print(f"object {o['object']} (grasps {grasps}): {o['shape']} "
              f"posterior {o['posterior'][o['shape']]:.2f}{doubt}")  # fmt: skip
    print(tally_line(doc["tally"]))
    from ..learn.doubt import batch_warning

    warning = batch_warning(doc["tally"]["ambiguous"], doc["tally"]["grasps"])
    if warning:
        print(warning)
    return 0


def recording_tally(answers: list[dict]) -> dict:
    """How a recording's grasps were named (docs/json.md ``tally``): ``{"grasps",
    "shapes": {shape: n}, "labelled", "correct", "ambiguous", "unknown"}``; ``correct`` counts
    the labelled grasps named as labelled (None when no grasp carries a label), ``ambiguous``
    the answers flagged (docs/doubt.md), ``unknown`` those answered unknown."""
    from collections import Counter

    labelled = [a for a in answers if a["label"]]
    return {
        "grasps": len(answers),
        "shapes": dict(Counter(str(a["shape"]) for a in answers).most_common()),
        "labelled": len(labelled),
        "correct": sum(a["shape"] == a["label"] for a in labelled) if labelled else None,
        "ambiguous": sum(a.get("ambiguous") is not None for a in answers),
        "unknown": sum(bool(a.get("unknown")) for a in answers),
    }


def tally_line(tally: dict) -> str:
    """``5 grasps: cylinder 3, sphere 2; 1 ambiguous; 4 of 5 labelled grasps named as
    labelled``."""
    shapes = ", ".join(f"{name} {n}" for name, n in tally["shapes"].items()) or "none"
    line = f"{plural(tally['grasps'], 'grasp')}: {shapes}"
    if tally.get("ambiguous"):
        line += f"; {tally['ambiguous']} ambiguous"
    if tally.get("unknown"):
        line += f"; {tally['unknown']} unknown (no family)"
    if tally["labelled"]:
        line += (f"; {tally['correct']} of {plural(tally['labelled'], 'labelled grasp')} "
                 "named as labelled")  # fmt: skip
    return line
