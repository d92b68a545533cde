"""``tactile-bullet calibrate``: the shape fit's coefficients for a hand, from known grasps."""

from __future__ import annotations

import argparse

from ..errors import UsageError
from .common import add_force_flag, emit_json, writable_file


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "calibrate",
        help="fit the shape fit's coefficients to a hand from grasps of known shape",
        description="Fit the shape fit's 24 per-finger coefficients (and the joint offsets the "
        "data allows) to the hand that made --data: any dataset whose records carry the shape "
        "label (simulated, or imported from a hand's CSV or bag with a shape column). Sizes and "
        "poses are fitted too, unless --sizes names them. How far the coefficients may move "
        "from the shipped ones is chosen by cross-validation; the shipped ones are kept where "
        "no refit names held-out grasps better. Use the file with --hand-calibration on "
        "identify, evaluate, compare and benchmark.",
    )
    parser.add_argument(
        "--data", required=True, metavar="KNOWN",
        help="dataset, record folder or record of grasps of known shape",
    )  # fmt: skip
    parser.add_argument("--out", required=True, metavar="FILE.toml", help="the hand calibration")
    parser.add_argument(
        "--sizes", metavar="FILE.toml",
        help="known sizes (m) of the calibration objects, a [shape] table each",
    )  # fmt: skip
    parser.add_argument(
        "--zeroed", action="store_true",
        help="fit the angles zeroed on the open hand, as robust-joints gives them to the shape "
        "fit (use this file with robust-joints models; without it, with raw-joints ones)",
    )  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    add_force_flag(parser, "hand calibration")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..experiments.training import records_from
    from ..perception.hand_fit import check_inputs, fit_hand
    from ..realhand.hand_calibration import load_sizes, render, write
    from ..realhand.names import hand_prefix

    out = writable_file(args.out, "--out", args.force)
    sizes = load_sizes(args.sizes) if args.sizes else {}
    records = records_from(args.data)
    usable = [r for r in records if "no_contact" not in r.flags]
    if not usable:
        raise UsageError(f"{args.data} holds no grasp that touched its object")
    shapes = [r.shape for r in usable]
    for name in sizes:
        if name not in shapes:
            raise UsageError(f"--sizes names {name!r}, but no grasp of {args.data} is one")
    known = [sizes.get(s) for s in shapes]
    if args.zeroed:
        from ..learn.robust import zeroed

        usable = [zeroed(r) for r in usable]
    angles = [r.fci_angles() for r in usable]
    check_inputs(angles, shapes, known)
    prefixes = {hand_prefix(r.joint_names) for r in usable}
    if len(prefixes) > 1:
        raise UsageError(f"{args.data} mixes hands ({', '.join(sorted(prefixes))}): calibrate one")
    hand = fit_hand(angles, shapes, known if sizes else None)
    report = {**hand.report, "angles": "zeroed" if args.zeroed else "raw",
              "skipped_no_contact": len(records) - len(usable)}  # fmt: skip
    text = render(hand.calibration, prefixes.pop(), str(args.data), hand.grasps_per_shape, report)
    write(out, text)
    doc = {"out": str(out), "grasps_per_shape": hand.grasps_per_shape,
           "kept_shipped": hand.kept_start, "report": report}  # fmt: skip
    if args.json:
        emit_json(doc)
        return 0
    counts = ", ".join(f"{n} {s}" for s, n in hand.grasps_per_shape.items())
    r = hand.report
    if hand.kept_start:
        verdict = "kept the shipped coefficients (no refit named held-out grasps better)"
    else:
        verdict = (f"refitted (pull toward the shipped coefficients: {hand.strength:g} x the "
                   "calibration grasps)")  # fmt: skip
        if r.get("family_terms"):
            verdict += ", with an offset per shape family"
    print(f"calibrated on {counts}: {verdict}")
    print(f"held-out calibration grasps named right: {100 * r['held_out_accuracy']:.0f}% "
          f"(shipped coefficients: {100 * r['start_held_out_accuracy']:.0f}%)")  # fmt: skip
    print(f"wrote {out}")
    return 0
