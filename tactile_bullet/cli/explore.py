"""``tactile-bullet explore``: grasp an object, and again where the hypotheses differ most,
until the answer is sure (docs/exploration.md)."""

from __future__ import annotations

import argparse

from ..errors import UsageError
from .common import (
    add_engine_flag,
    add_force_flag,
    count,
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
from .shape_info import add_object_options, mesh_shape


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "explore",
        help="grasp an object, then again where the shapes in doubt differ most",
        description="Grasp --shape (or --mesh) at the pose given; while the default "
        "identifier's fused answer is ambiguous or unknown, choose the next pose of the hand "
        "(along O-O', across it, turned about the palm normal, within the reachable set) where "
        "the likely shapes, simulated at the sizes and pose the shape fit gives them, predict "
        "the most different answers, and grasp there; up to --max-grasps.",
    )
    add_object_options(
        parser,
        "the first grasp's object offset in metres (default 0,0,0; reachable: +-0.015 along "
        "O-O', +-0.010 along the fingers)",
        "the first grasp's object rotation about the palm normal, degrees (reachable: +-25; "
        "default 0)",
    )
    parser.add_argument(
        "--max-grasps", type=count(1), default=3, metavar="K",
        help="at most K grasps (default 3; at most 7, the first pose and its reachable moves)",
    )
    parser.add_argument(
        "--strategy", choices=("planned", "random", "repeat"), default="planned",
        help="how the next pose is chosen: planned (expected information gain, the default), "
        "random (a reachable move) or repeat (the same pose): the baselines",
    )  # fmt: skip
    parser.add_argument(
        "--fusion", choices=("model", "simulated"), default="model",
        help="how later grasps are read: model (each grasp's own answer, the default) or "
        "simulated (how well each likely shape, simulated at that pose, explains the grasp)",
    )  # fmt: skip
    parser.add_argument(
        "--model", metavar="FILE",
        help="the model that reads each grasp and plans (a file written by `train` or "
        "`adapt`; default: the built-in default identifier, docs/robustness.md)",
    )  # fmt: skip
    parser.add_argument("--plot", metavar="PNG", help="draw the posterior after each grasp")
    add_force_flag(parser, "--plot")
    parser.add_argument("--seed", type=seed_number, default=0, help="seed (random strategy)")
    add_engine_flag(parser, hand_model=True)
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..experiments.exploration import check_reachable, explore
    from ..records import ControllerSettings, Pose

    params = {k: parse_number(v, f"--param {k}") for k, v in parse_key_values(args.param).items()}
    pose = check_reachable(Pose(parse_offset(args.offset), parse_rotation(args.rotation)),
                           "the first pose")  # fmt: skip
    outputs = output_files({"plot": args.plot}, args.force)
    if "plot" in outputs:
        image_file(outputs["plot"], "--plot", "matplotlib")
    from ..sim.grasp import resolve_shape

    target = mesh_shape(args) or resolve_shape(args.shape)
    if args.mesh and args.param:
        raise UsageError("--param sizes a --shape; a --mesh has its own size")
    controller = ControllerSettings(**engine_settings(args))
    from ..learn.default import resolve_model

    model = resolve_model(args.model)  # a damaged or foreign file: one line, before any grasp
    log = None if args.json else print
    doc = explore(target, params or None, pose, controller, max_grasps=args.max_grasps,
                  model=model, strategy=args.strategy, seed=args.seed, log=log,
                  fusion=args.fusion)  # fmt: skip
    doc.pop("fused")
    fused = doc["answer"]
    doc["answer"] = {
        "shape": fused["shape"], **_identifier(args.model, model),
        "probabilities": fused["posterior"], "ambiguous": fused["ambiguous"],
        "unknown": fused["unknown"], "grasps": fused["grasps"],
        "distinct_grasps": fused["distinct_grasps"], "unknown_grasps": fused["unknown_grasps"],
    }  # fmt: skip
    doc["object"] = {"shape": getattr(target, "name", str(target)), "params": params}
    if "plot" in outputs:
        from ..experiments.figures_exploration import plot_posteriors

        plot_posteriors(doc, outputs["plot"])
        doc["outputs"] = {"plot": str(outputs["plot"])}
    if args.json:
        emit_json(doc)
        return 0
    answer = doc["answer"]
    p = answer["probabilities"][answer["shape"]]
    made = f"{answer['grasps']} grasp(s)"
    if answer["distinct_grasps"] < answer["grasps"]:
        made += f", {answer['grasps'] - answer['distinct_grasps']} of them a repeat counted once"
    line = f"identified after {made}: {answer['shape']} (posterior {p:.2f})"
    if answer["unknown"]:
        line = (f"identified after {made}: UNKNOWN - no family explains "
                f"{answer['unknown_grasps']} of the {answer['distinct_grasps']} grasps fused "
                f"(each judged against {answer['shape']}, the best guess)")
    elif answer["ambiguous"]:
        line += f" - AMBIGUOUS: {answer['ambiguous'][0]} or {answer['ambiguous'][1]}"
    print(line)
    for d in doc["decisions"]:
        source = (f"{d['simulated']} new simulated grasps" if d["simulated"] else
                  "the simulated grasps of the decision before (none new)")  # fmt: skip
        print(f"  a next pose chosen in {d['seconds']:.2f} s from {source} of "
              f"{', '.join(h for h, _ in d['hypotheses'])}")  # fmt: skip
    if doc["stopped"]:
        print(f"  stopped after {made}: {doc['stopped']} (--strategy random grasps at other "
              "poses)")  # fmt: skip
    if "plot" in outputs:
        print(f"wrote plot: {outputs['plot']}")
    return 0


def _identifier(path: str | None, model) -> dict:
    """``identifier`` and ``method`` of the answer: the default's description, or the model
    file's descriptor and classifier."""
    from ..learn.default import DEFAULT_NAME, default_meta

    if path is None or str(path) == DEFAULT_NAME:
        meta = default_meta()
        return {"identifier": "default",
                "method": {"name": meta.get("method"), "training": meta.get("training")}}
    return {"identifier": "model",
            "method": {"name": f"{model.descriptor} + {model.classifier}", "training": None,
                       "file": str(path)}}  # fmt: skip
