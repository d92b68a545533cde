"""``tactile-bullet grasp``: one enclosure grasp, its summary, record, snapshot and plot."""

from __future__ import annotations

import argparse
import math

from ..errors import UsageError
from .common import (
    add_engine_flag,
    add_force_flag,
    emit_json,
    engine_settings,
    image_file,
    output_files,
    parse_key_values,
    parse_number,
    parse_offset,
    parse_rotation,
    seed_number,
)
from .shape_info import add_object_options, mesh_block, mesh_shape, mesh_summary


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "grasp",
        help="simulate one enclosure grasp (thesis Algorithm 1) on a shape",
        description="Simulate one enclosure grasp of the Shadow hand on a static object.",
    )
    add_object_options(
        parser,
        "object offset from its resting place in metres, palm frame: x along O-O', y along the "
        "palm normal (positive toward the palm), z along the fingers (default 0,0,0)",
        "object rotation about the palm normal in degrees, within +-90 (default 0)",
    )
    parser.add_argument(
        "--mode", choices=("torque", "contact"), default="torque",
        help="stop rule of a closing joint: torque (its effort over --thres) or contact (a "
        "phalanx touches) (default torque)",
    )  # fmt: skip
    parser.add_argument(
        "--delta", type=float, help="joint step per control tick in rad (default 0.006)"
    )
    parser.add_argument("--thres", type=float, help="torque threshold thresT in N m (default 0.35)")
    parser.add_argument(
        "--max-time", type=float,
        help="simulated time limit in s, at most 60 (default 4)",
    )
    parser.add_argument(
        "--preshape", action="store_true",
        help="start each finger where its sweep comes within 5 mm of the object (1.2x faster, "
        "final angles within ~2.5 deg)",
    )  # fmt: skip
    parser.add_argument(
        "--early-stop", action="store_true",
        help="stop closing a finger once the dynamic detector finds it out of contact "
        "(fewer steps when a finger misses the object)",
    )  # fmt: skip
    add_engine_flag(parser, hand_model=True)
    parser.add_argument(
        "--coupling", choices=("j2-first", "equal-torque", "distal-first"), default="j2-first",
        help="how bullet's controller shares the J1/J2 tendon's travel (docs/transfer.md; "
        "default j2-first); mujoco's tendon shares it by its physics",
    )  # fmt: skip
    parser.add_argument(
        "--tendon-spring", type=float, metavar="K",
        help="mujoco: a return spring on each J1, N m/rad (0.3: the middle joint closes first)",
    )  # fmt: skip
    parser.add_argument(
        "--servo-stiffness", type=float, metavar="K",
        help="mujoco: the long fingers' servo stiffness, N m/rad (the model's own: ours 20)",
    )  # fmt: skip
    parser.add_argument(
        "--seed", type=seed_number, default=0,
        help="seed stored in the record; the grasp itself is deterministic (default 0)",
    )  # fmt: skip
    parser.add_argument("--out", help="write the GraspRecord to this .npz file")
    parser.add_argument("--snapshot", help="render the grasp to this PNG (CPU renderer)")
    parser.add_argument("--plot", help="draw FCI and signatures of the grasp to this PNG")
    parser.add_argument(
        "--video", metavar="FILE",
        help="replay the closing hand into this .mp4 or .gif (CPU renderer, two views of "
        "240 px, 30 frames per second)",
    )  # fmt: skip
    parser.add_argument(
        "--video-every", type=int, metavar="K",
        help="draw every K-th recorded sample (60 per simulated second) into --video "
        "(default: 2, real time, or more to keep within 120 frames)",
    )  # fmt: skip
    add_force_flag(parser, "--out, --snapshot, --plot and --video files")
    parser.add_argument("--gui", action="store_true", help="show PyBullet's window")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def _controller(args):
    from ..records import ControllerSettings

    overrides = {"mode": args.mode, "preshape": args.preshape, "early_stop": args.early_stop,
                 "coupling": args.coupling}  # fmt: skip
    overrides.update(engine_settings(args))
    for key, value in (("delta", args.delta), ("thres_t", args.thres), ("max_time", args.max_time),
                       ("tendon_spring", args.tendon_spring),
                       ("servo_stiffness", args.servo_stiffness)):  # fmt: skip
        if value is not None:
            overrides[key] = value
    return ControllerSettings(**overrides)


def run(args: argparse.Namespace) -> int:
    from ..records import Pose

    params = {k: parse_number(v, f"--param {k}") for k, v in parse_key_values(args.param).items()}
    offset = parse_offset(args.offset)
    pose = Pose(offset, parse_rotation(args.rotation))
    controller = _controller(args)
    outputs = output_files(
        {f: getattr(args, f) for f in ("out", "snapshot", "plot", "video")}, args.force
    )
    for flag in ("snapshot", "plot"):
        if flag in outputs:
            image_file(outputs[flag], f"--{flag}", "cv2" if flag == "snapshot" else "matplotlib")
    if "video" in outputs:
        from ..sim.render import check_video_path, video_step

        check_video_path(outputs["video"])
        video_step(2, args.video_every)  # refuses a bad --video-every before simulating
    elif args.video_every is not None:
        raise UsageError("--video-every sets the frames of --video: give --video too")

    from ..sim.grasp import resolve_shape, timed_grasp

    shape = mesh_shape(args) or resolve_shape(args.shape)
    hook = None
    if "snapshot" in outputs:

        def hook(engine):
            engine.snapshot(outputs["snapshot"])

    record, wall = timed_grasp(
        shape, params, pose, controller, args.seed, gui=args.gui, scene_hook=hook
    )
    if "out" in outputs:
        from ..records import save_record

        save_record(record, outputs["out"])
    video = None
    if "video" in outputs:
        from ..sim.render import write_video

        video = write_video(record, shape, outputs["video"], every=args.video_every)
    signature = _signature_block(record)
    if "plot" in outputs:
        from ..experiments.figures_signature import plot_grasp_signature

        plot_grasp_signature(record, outputs["plot"])
    from ..perception.shape_fit import shape_fit_summary
    from ..perception.shape_model import use_own
    from ..realhand.hand_calibration import record_calibration

    with use_own(record_calibration(record)):  # our MuJoCo hand: its own, as the cross-check
        fit_block = shape_fit_summary(record)
    doc = {
        "shape": record.shape,
        "params": dict(record.params),
        "pose": {"offset": list(pose.offset), "rotation_deg": math.degrees(pose.rotation)},
        "mode": controller.mode,
        "engine": controller.engine,
        "fingers_in_contact": list(record.fingers_in_contact),
        "joint_angles": record.final_dict(),
        "sim_time_s": record.sim_time_s,
        "wall_time_s": wall,
        "steps": record.steps,
        "flags": list(record.flags),
        "signature": signature,
        "temporal": _temporal_block(record),
        "shape_fit": fit_block,
        "outputs": {k: str(v) for k, v in outputs.items()},
    }
    if video is not None:
        doc["video"] = {k: v for k, v in video.items() if k != "path"}
    doc["answer"] = grasp_answer(record, doc["shape_fit"], signature)
    if (mesh := mesh_block(shape)) is not None:
        doc["mesh"] = mesh
    if args.json:
        emit_json(doc)
    else:
        _print_summary(doc)
        if "mesh" in doc:
            print(mesh_summary(doc["mesh"]))
    return 0


def grasp_answer(record, fit: dict | None, signature: dict | None) -> dict:
    """The one answer of a grasp (docs/json.md ``answer``): the default identifier's
    (:mod:`tactile_bullet.learn.default`, the robustness matrix's winner) with its doubt
    (``ambiguous``, ``unknown``) and probabilities; the training-free identifiers' names are
    ``others``, detail that may disagree. ``rotation_deg`` is the calibrated estimate of the
    object's turn (the signature's line slope), None with ``rotation_withheld`` saying why.
    No shape where the grasp touched too little."""
    by_signature = signature.get("identified") if signature else None
    others = {"shape-fit": fit["shape"] if fit else None, "signature": by_signature}
    rotation = signature.get("rotation_estimate_deg") if signature else None
    withheld = None
    if rotation is None:
        withheld = (signature or {}).get("rotation_estimate_withheld") or "no signature"
    if signature and signature.get("reason"):  # touched too little: a fit of a fist says nothing
        return {"shape": None, "identifier": None, "others": {}, "ambiguous": None,
                "unknown": False, "rotation_deg": None,
                "rotation_withheld": signature["reason"]}  # fmt: skip
    from ..experiments.training import identify
    from ..learn.default import default_meta, default_model

    doc = identify(default_model(), record)
    meta = default_meta()
    return {
        "shape": doc["shape"], "identifier": "default",
        "method": {"name": meta.get("method"), "training": meta.get("training")},
        "probabilities": doc["probabilities"], "margin": doc.get("margin"),
        "ambiguous": doc.get("ambiguous"), "unknown": bool(doc.get("unknown")),
        "novelty": doc.get("novelty"), "unknown_why": doc.get("unknown_why"),
        "axis_residual_mm": doc.get("axis_residual_mm"),
        "profile_residual_mm": doc.get("profile_residual_mm"),
        "cross_check": doc.get("cross_check"), "renamed_from": doc.get("renamed_from"),
        "rotation_deg": rotation, "rotation_withheld": withheld, "others": others,
    }  # fmt: skip


def _signature_block(record) -> dict | None:
    """The `signature` block (docs/json.md), or None where the grasp gives no signature."""
    from ..perception.summary import signature_summary

    try:
        return signature_summary(record)
    except UsageError:
        return None


def _temporal_block(record) -> dict | None:
    """Both non-contact detectors' verdicts (thesis ch. 3), None without a time series."""
    from ..perception.temporal import temporal_summary

    try:
        return temporal_summary(record)
    except UsageError:
        return None


def _print_summary(doc: dict) -> None:
    from ..hand import FINGERS

    params = ", ".join(f"{k}={v:g} m" for k, v in doc["params"].items())
    what = f"{doc['shape']} ({params or ('a mesh' if 'mesh' in doc else 'no sizes')})"
    print(f"{what}, offset {doc['pose']['offset']} m, "
          f"rotation {doc['pose']['rotation_deg']:g} deg, {doc['mode']} mode, "
          f"{doc['engine']} engine")  # fmt: skip
    print(_answer_line(doc))
    answer = doc["answer"]
    if answer["shape"] is not None:
        if answer["rotation_deg"] is not None:
            print(f"  object turned about {answer['rotation_deg']:.1f} deg (signature slope, "
                  "calibrated)")  # fmt: skip
        else:
            print(f"  object's turn withheld: {answer['rotation_withheld']}")
    print("detail (other identifiers, training-free; they may disagree with the answer):")
    sig = doc["signature"]
    if sig and sig.get("reason"):
        print(f"  signature: {sig['reason']}")
    elif sig:
        print(f"  signature, DTW to the thesis patterns: {sig['identified']}, nearest pattern "
              f"{sig['nearest_pattern']}, alpha {sig['alpha_deg']:.1f} deg")  # fmt: skip
    fit = doc["shape_fit"]
    if fit:
        sizes = ", ".join(f"{k} {v * 1000:.1f} mm" for k, v in fit["params"].items())
        print(f"  shape fit: {fit['shape']} ({sizes}, residual {fit['residual']:.3f} rad)")
    touching = ", ".join(doc["fingers_in_contact"]) or "none"
    print(f"  fingers in contact: {touching} (the simulator's contacts)")
    temporal = doc.get("temporal")
    if temporal:
        print(f"  {_detector_line(doc['fingers_in_contact'], temporal['dynamic'], doc['engine'])}")
    print(f"  simulated {doc['sim_time_s']:.3f} s in {doc['steps']} steps, "
          f"wall time {doc['wall_time_s']:.3f} s")  # fmt: skip
    if doc["flags"]:
        print(f"  flags: {', '.join(doc['flags'])}")
    print("  final joint angles (deg):")
    angles = doc["joint_angles"]
    for finger in FINGERS:
        names = [n for n in angles if n.lower().startswith(finger)]
        row = "  ".join(f"{n}={math.degrees(angles[n]):6.1f}" for n in names)
        print(f"    {finger}: {row}")
    for key, path in doc["outputs"].items():
        print(f"wrote {key}: {path}")


def _detector_line(in_contact, dynamic: dict, engine: str) -> str:
    """What chapter 3's dynamic detector reads from the joint angles alone, beside the
    simulator's contacts: never a second, contradicting "off the object" list. Where the two
    disagree (on MuJoCo often: the detector's thresholds were fitted on bullet grasps), the
    line names the fingers they disagree on and says which is the simulator's truth."""
    off = list(dynamic["non_contact"])
    when = f"decided at {dynamic['decided_at_s']:.2f} s"
    disputed = [f for f in off if f in set(in_contact)]
    if not disputed:
        return (f"fingers off the object by the joint angles alone (dynamic detector): "
                f"{', '.join(off) or 'none'}, {when}")  # fmt: skip
    tuned = "" if engine == "bullet" else (
        f"; its thresholds were fitted on bullet grasps, not {engine}"
    )
    agreed = [f for f in off if f not in disputed]
    more = f" (and off: {', '.join(agreed)})" if agreed else ""
    return (f"dynamic detector (joint angles alone) would call {', '.join(disputed)} off the "
            f"object{more}, {when}: wrong here, the simulator has them in contact"
            f"{tuned}")  # fmt: skip


def unknown_reason(doc: dict, who: str = "the model") -> str:
    """Why an answer is ``unknown``, in words (its ``unknown_why``)."""
    from ..learn.doubt import NOT_PROFILE, NOT_REVOLUTION

    if doc.get("unknown_why") == NOT_REVOLUTION:
        return (f"its contacts fit no solid of revolution ({doc.get('axis_residual_mm')} mm "
                "off the best axis): an object of no family")
    if doc.get("unknown_why") == NOT_PROFILE:
        return (f"its contacts fit no {doc.get('shape')} ({doc.get('profile_residual_mm')} mm "
                "from the best one's surface): an object of no family")
    return (f"the grasp is unlike every grasp {who} learnt (an object of no family it knows, "
            "or a pose it never saw)")


def _answer_line(doc: dict) -> str:
    """``identified: SHAPE by the default identifier (METHOD)``, with its doubt: the line
    the ``answer`` block prints as; nothing below it is another answer, only detail."""
    answer = doc["answer"]
    if answer["shape"] is None:
        return "identified: nothing (the grasp touched too little)"
    how = f"the default identifier ({answer['method']['name']})"
    if answer.get("unknown"):
        return (f"identified: UNKNOWN - {unknown_reason(answer, how)}; best guess "
                f"{answer['shape']}")
    if answer.get("renamed_from"):  # the probabilities are the classifier's, for its answer
        p = answer["probabilities"].get(answer["renamed_from"])
        line = f"identified: {answer['shape']} by {how} ({renamed_reason(answer)}" + (
            f"; the classifier's p={p:.2f})" if p is not None else ")")
    else:
        p = answer["probabilities"].get(answer["shape"])
        line = f"identified: {answer['shape']} by {how}" + (f", p={p:.2f}" if p is not None
                                                              else "")  # fmt: skip
    if answer.get("ambiguous"):
        line += f" - AMBIGUOUS: {answer['ambiguous'][0]} or {answer['ambiguous'][1]}"
    return line


def renamed_reason(doc: dict) -> str:
    """Why an answer is not its classifier's (its ``renamed_from``), in words."""
    return (f"the classifier read {doc['renamed_from']}; the contacts fit no "
            f"{doc['renamed_from']} but a {doc['shape']}")
