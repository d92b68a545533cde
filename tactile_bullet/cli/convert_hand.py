"""``tactile-bullet convert-hand``: another Shadow hand's MJCF as one file ``--hand-model``
reads (``sim/hand_conversion.py``)."""

from __future__ import annotations

import argparse

from .common import add_force_flag, emit_json


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "convert-hand",
        help="turn another Shadow hand's MJCF into one file --hand-model reads",
        description="Convert an independently written Shadow hand into one MJCF file that "
        "`--hand-model` reads (docs/independent_hand.md): the MuJoCo Menagerie's "
        "shadow_hand/right_hand.xml (visual geoms dropped, missing meshes replaced by "
        "primitives) or gymnasium-robotics' gymnasium_robotics/envs/assets/hand folder "
        "(joints renumbered, each long finger's servo on a J1 + J2 tendon). Prints each change.",
    )
    parser.add_argument(
        "source", metavar="SOURCE",
        help="the Menagerie's shadow_hand/right_hand.xml, or gymnasium-robotics' hand folder",
    )  # fmt: skip
    parser.add_argument("--out", required=True, metavar="HAND.xml", help="the MJCF file to write")
    parser.add_argument(
        "--layout", default="auto", choices=("auto", "menagerie", "gymnasium"),
        help="how SOURCE is written (default auto: a folder is gymnasium-robotics', a file the "
        "Menagerie's)",
    )  # fmt: skip
    add_force_flag(parser, "--out")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..errors import UsageError
    from ..sim.hand_conversion import convert_hand, detect_layout, write_hand
    from .common import writable_file

    if not args.out.lower().endswith(".xml"):
        raise UsageError(f"--out {args.out} must end in .xml (an MJCF model file)")
    out = writable_file(args.out, "--out", args.force)  # before any conversion work
    layout = detect_layout(args.source, args.layout)
    conversion = convert_hand(args.source, layout)
    write_hand(conversion, out)
    doc = {
        "source": str(args.source),
        "layout": conversion.layout,
        "out": str(out),
        "changes": list(conversion.changes),
    }
    if args.json:
        emit_json(doc)
        return 0
    for line in conversion.changes:
        print(f"  {line}")
    print(f"wrote {out}")
    return 0
