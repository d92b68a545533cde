"""``tactile-bullet identify``: name the shape of one new grasp with a saved model."""

from __future__ import annotations

import argparse
import math

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
from .import_ import add_recording_options, identify_recording
from .shape_info import add_mesh_options, mesh_shape


def ambiguity_text(doc) -> str:
    """What the text output adds to an answer the model is unsure of (empty otherwise)."""
    pair = doc.get("ambiguous")
    if not pair:
        return ""
    return f" - AMBIGUOUS: {pair[0]} or {pair[1]} (margin {doc['margin']:.3f})"


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "identify",
        help="simulate a grasp (or read a record) and name its shape with a model",
        description="Identify the shape of one grasp: simulate a new one on --shape, or read "
        "a saved GraspRecord with --record, and print the model's answer and probabilities.",
    )
    parser.add_argument("--model", required=True, help="model file written by `train`")
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
    from ..experiments.workflow import identify
    from ..learn.models import load_model

    if args.recording:
        return identify_recording(args)
    if args.calibration or args.marker or args.topic != "/joint_states" or args.gap != "0.5":
        raise UsageError("--topic, --marker, --gap and --calibration read a --recording")
    model = load_model(args.model)
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
        print(f"identified: {doc['shape']}{ambiguity_text(doc)} (grasped: {record.shape})")
        ranked = sorted(doc["probabilities"].items(), key=lambda kv: -kv[1])
        for name, p in ranked:
            print(f"  {name:<20} {p:6.3f}")
    return 0
