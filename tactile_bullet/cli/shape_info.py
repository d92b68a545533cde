"""``tactile-bullet shape-info``: what the hand will grasp of a mesh file, and its theory.

Size, main axis, watertightness, triangle counts before and after simplification, the radius
profile r(x) by slicing and the theoretical signature it gives (with the nearest primitive
family's pattern). Also the ``--mesh`` options that ``grasp`` and ``identify`` share.
"""

from __future__ import annotations

import argparse

from ..errors import UsageError
from .common import add_force_flag, emit_json, parse_number, writable_file


def add_mesh_options(parser: argparse.ArgumentParser, required: bool = False) -> None:
    """--mesh FILE and the options that say how to read it (shared by grasp and identify)."""
    from ..objects.mesh_formats import AXES, FORMATS, UNITS

    if required:
        parser.add_argument(
            "--mesh", required=True, metavar="FILE", help=f"mesh file ({', '.join(FORMATS)})"
        )
    group = parser.add_argument_group("mesh files (with --mesh)")
    group.add_argument("--unit", choices=tuple(UNITS), help="length unit of the file (default m)")
    group.add_argument("--scale", metavar="S", help="scale factor applied after --unit")
    group.add_argument("--axis", choices=AXES, help="main axis O-O' (default auto: inertia)")
    group.add_argument("--name", help="object name, the label of its grasps (default: stem)")


def mesh_shape(args: argparse.Namespace):
    """The MeshShape ``--mesh`` names, or None without --mesh (then the mesh-only options
    are refused rather than ignored)."""
    given = [f"--{k}" for k in ("unit", "scale", "axis", "name") if getattr(args, k, None)]
    if not getattr(args, "mesh", None):
        if given:
            raise UsageError(f"{given[0]} applies to --mesh only")
        return None
    if getattr(args, "param", None):
        raise UsageError("--param sets a --shape's sizes: a --mesh has its own (--unit and "
                         "--scale size it)")  # fmt: skip
    from ..objects.meshes import load_mesh

    scale = 1.0 if args.scale is None else parse_number(args.scale, "--scale")
    return load_mesh(args.mesh, args.unit or "m", scale, args.axis or "auto", args.name)


def mesh_block(shape) -> dict | None:
    """``grasp --json``'s ``mesh`` block: which file, and its nearest primitive pattern."""
    if getattr(shape, "source", None) is None:
        return None
    from ..experiments.mesh_report import describe

    return describe(shape)


def mesh_summary(block: dict) -> str:
    """One line for ``grasp``'s text output: the file and its theoretical pattern."""
    pattern = block["pattern"]
    return (
        f"mesh: {block['file']} (sha256 {block['sha256'][:12]}, {block['triangles']['collision']}"
        f" triangles in collision); its r(x) pattern is nearest the {pattern['nearest']}'s"
    )


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "shape-info",
        help="size, axis, r(x) and theoretical signature of a mesh file",
        description="Process a mesh file as the hand will grasp it and report its size, main "
        "axis, watertightness, triangle counts, radius profile r(x) and the theoretical "
        "signature it gives, with the nearest primitive family's pattern.",
    )
    add_mesh_options(parser, required=True)
    parser.add_argument("--plot", metavar="PNG", help="draw r(x) and its pattern to this PNG")
    add_force_flag(parser, "plot")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    plot = writable_file(args.plot, "--plot", args.force) if args.plot else None
    shape = mesh_shape(args)
    from ..experiments.mesh_report import describe

    doc = describe(shape, profile_points=len(shape.profile_x))
    if plot is not None:
        from ..experiments.mesh_report import plot_profile

        plot_profile(shape, plot)
        doc["outputs"] = {"plot": str(plot)}
    if args.json:
        emit_json(doc)
    else:
        print(_text(doc))
    return 0


def _text(doc: dict) -> str:
    size = doc["size_m"]
    tri = doc["triangles"]
    axis = ", ".join(f"{c:+.3f}" for c in doc["axis"]["direction_in_file"])
    radii = doc["radius_profile"]["r"]
    pattern = doc["pattern"]
    ranked = sorted(pattern["distances"].items(), key=lambda kv: kv[1])
    lines = [
        f"{doc['name']}: {doc['file']} (sha256 {doc['sha256'][:12]}, unit {doc['unit']}, "
        f"scale {doc['scale']:g})",
        f"  size: {size['length'] * 1000:.1f} mm along O-O' x {size['y'] * 1000:.1f} x "
        f"{size['z'] * 1000:.1f} mm; widest section r = {max(radii) * 1000:.1f} mm "
        f"(equivalent), {doc['max_radius_m'] * 1000:.1f} mm from the axis at most",
        f"  axis O-O' ({doc['axis']['mode']}): ({axis}) in the file's frame",
        f"  watertight: {'yes' if doc['watertight'] else 'no'}"
        + (" (holes filled)" if doc["filled_holes"] else ""),
        f"  triangles: {tri['input']} in the file, {tri['analysis']} analysed, "
        f"{tri['collision']} in collision ({doc['collision']})",
        f"  nearest primitive pattern: {pattern['nearest']} ("
        + ", ".join(f"{k} {v:.2f}" for k, v in ranked)
        + ")",
    ]
    if "outputs" in doc:
        lines.append(f"wrote plot: {doc['outputs']['plot']}")
    return "\n".join(lines)


def add_object_options(parser, offset_help: str, rotation_help: str) -> None:
    """The object of a simulated grasp: ``--shape`` or ``--mesh`` (with the mesh options),
    ``--param`` sizes, ``--offset`` and ``--rotation`` (each command says its own range)."""
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--shape", help="shape name (see `tactile-bullet shapes`)")
    what.add_argument("--mesh", metavar="FILE", help="a mesh file (see docs/meshes.md)")
    add_mesh_options(parser)
    parser.add_argument(
        "--param", action="append", metavar="KEY=VALUE", help="shape size in metres (repeatable)"
    )
    parser.add_argument("--offset", default="0,0,0", metavar="X,Y,Z", help=offset_help)
    parser.add_argument("--rotation", default="0", metavar="DEG", help=rotation_help)
