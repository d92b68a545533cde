"""Small helpers shared by the subcommands: key=value and vector parsing, output paths
(JSON output and progress come from :mod:`tactile_bullet.console`)."""

from __future__ import annotations

import argparse
import contextlib
import math
import os
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..console import emit_json, log_lines, progress, show_progress  # noqa: F401  (re-exported for the subcommands)
from ..errors import UsageError


def parse_number(text: str, what: str) -> float:
    """A finite float; Python's digit separators (``0.0_4``) are refused, as in tables: a
    typo reads as another number."""
    try:
        if "_" in text:
            raise ValueError(text)
        value = float(text)
    except ValueError:
        raise UsageError(f"{what} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise UsageError(f"{what} must be finite, got {text!r}")
    return value


def parse_vector(text: str, n: int, what: str) -> tuple[float, ...]:
    """'x,y,z' -> floats, with a clear error for anything else."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != n or any(not p for p in parts):
        raise UsageError(f"{what} must be {n} comma-separated numbers, got {text!r}")
    return tuple(parse_number(p, what) for p in parts)


def parse_key_values(items: Sequence[str] | None, what: str = "--param") -> dict[str, str]:
    """['k=v', ...] -> {k: v} (values left as text; callers convert); a key given twice is an
    error, not the last value silently."""
    out: dict[str, str] = {}
    for item in items or ():
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise UsageError(f"{what} expects key=value, got {item!r}")
        if key.strip() in out:
            raise UsageError(f"{what} {key.strip()} is given twice ({out[key.strip()]} and "
                             f"{value.strip()}): give it once")  # fmt: skip
        out[key.strip()] = value.strip()
    return out


def convert_value(text: str) -> Any:
    """Best-effort literal for estimator parameters: int, float, bool, None, else the string."""
    lowered = text.lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    if lowered in ("none", "null"):
        return None
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def estimator_params(items: Sequence[str] | None, what: str = "--param") -> dict[str, Any]:
    """KEY=VALUE texts -> typed values (int, float, bool, None or string)."""
    return {k: convert_value(v) for k, v in parse_key_values(items, what).items()}


def writable_file(path: str | os.PathLike, what: str = "output", force: bool = False) -> Path:
    """Check up front that ``path`` can be written, so long work is not lost at the end; an
    existing file is refused unless ``force`` (nothing on disk is overwritten unasked)."""
    from ..files import probe_folder, refuse_special

    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    refuse_special(path, what)
    if path.is_dir():
        raise UsageError(f"{what} path {path} is a directory")
    if not parent.is_dir():
        raise UsageError(f"{what} directory {parent} does not exist")
    if path.exists() and not force:
        raise UsageError(f"{what} {path} already exists; add --force to overwrite it")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{what} path {path} is not writable")
    probe_folder(parent, f"{what} directory")
    return path


def add_force_flag(parser, what: str) -> None:
    """``--force``: the one way to let a command replace files that already exist."""
    parser.add_argument(
        "--force", action="store_true", help=f"overwrite existing {what} (refused otherwise)"
    )


def add_engine_flag(parser, hand_model: bool = False) -> None:
    """``--engine NAME``: which physics engine simulates the grasps (default: the sweep's or
    the controller's, ``bullet``); with ``hand_model``, ``--hand-model FILE.xml`` too."""
    parser.add_argument(
        "--engine", metavar="NAME",
        help="physics engine: bullet (default) or mujoco (pip install 'tactile-bullet[mujoco]'), "
        "or one a plugin registers",
    )  # fmt: skip
    if hand_model:
        parser.add_argument(
            "--hand-model", metavar="FILE.xml",
            help="another MJCF Shadow hand for the mujoco engine, found by Shadow's joint names "
            "(docs/engines.md)",
        )  # fmt: skip


def engine_settings(args: argparse.Namespace) -> dict[str, str]:
    """The controller fields ``--engine`` and ``--hand-model`` ask for (none given: empty),
    checked before any work: an unknown or missing engine, or a hand model lacking a joint or
    an actuator, is a UsageError naming it. ``--hand-model`` implies ``--engine mujoco``."""
    out: dict[str, str] = {}
    engine = engine_name(args)
    model = getattr(args, "hand_model", None)
    if model is not None:
        if engine not in (None, "mujoco"):
            raise UsageError(f"--hand-model is an MJCF model: not with --engine {engine}")
        engine = engine_name(argparse.Namespace(engine="mujoco"))
        from ..sim.engines.mujoco_hand import load_hand_spec, model_digest

        load_hand_spec(model)
        out["hand_model"] = str(Path(model).resolve())
        out["hand_model_digest"] = model_digest(model)[0]
    if engine is not None:
        out["engine"] = engine
    return out


def engine_name(args: argparse.Namespace) -> str | None:
    """The ``--engine`` asked for, checked before any work (unknown or not installed: a
    UsageError naming the installed ones or how to install it); None when not given."""
    name = getattr(args, "engine", None)
    if name is None:
        return None
    from ..plugins import get_engine

    get_engine(name)
    return name


def output_files(paths: Mapping[str, str | None], force: bool) -> dict[str, Path]:
    """Check every output file of a command before any work: writable, not already there
    (unless ``force``), and no two flags naming the same file (the second would silently
    replace the first). ``paths`` maps a flag name (without --) to its value or None."""
    out: dict[str, Path] = {}
    for flag, value in paths.items():
        if not value:
            continue
        path = writable_file(value, f"--{flag}", force)
        for other, seen in out.items():
            if os.path.abspath(seen) == os.path.abspath(path):
                raise UsageError(f"--{other} and --{flag} name the same file {path}")
        out[flag] = path
    return out


def image_file(path: Path, what: str, backend: str) -> Path:
    """Refuse, before simulating, an image name whose format the writer cannot produce
    (``backend``: "cv2" for snapshots, "matplotlib" for plots)."""
    suffix = path.suffix.lower().lstrip(".")
    if backend == "cv2":
        import cv2

        ok = bool(suffix) and bool(cv2.haveImageWriter(f"x.{suffix}"))
        formats = "png, jpg, bmp, tiff, webp"
    else:
        from matplotlib.figure import Figure

        supported = Figure().canvas.get_supported_filetypes()
        ok = suffix in supported
        formats = ", ".join(sorted(supported))
    if not ok:
        raise UsageError(
            f"{what} {path}: cannot write a {suffix or 'suffix-less'} image (use one of {formats})"
        )
    return path


def parse_offset(text: str, what: str = "--offset") -> tuple[float, float, float]:
    """'x,y,z' metres, each within the records' MAX_OFFSET_M."""
    from ..records import MAX_OFFSET_M

    offset = parse_vector(text, 3, what)
    if any(abs(v) > MAX_OFFSET_M for v in offset):
        raise UsageError(f"{what} {text} is out of range: each coordinate within "
                         f"+-{MAX_OFFSET_M:g} m")  # fmt: skip
    return offset  # type: ignore[return-value]


def parse_rotation(text: str, what: str = "--rotation") -> float:
    """Degrees -> radians, within the records' MAX_ROTATION_DEG."""
    from ..records import MAX_ROTATION_DEG

    degrees = parse_number(text, what)
    if abs(degrees) > MAX_ROTATION_DEG:
        raise UsageError(
            f"{what} {text} is out of range [-{MAX_ROTATION_DEG:g}, {MAX_ROTATION_DEG:g}] degrees"
        )
    return math.radians(degrees)


MAX_SEED = 2**32 - 1


def seed_number(text: str) -> int:
    """argparse type of every --seed: numpy seeds are integers in [0, 2**32)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be from 0 to {MAX_SEED}, got {value}")
    return value


def count(lo: int, hi: int | None = None):
    """argparse type: an integer in [lo, hi] (``hi`` None: no upper bound)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
        if value < lo or (hi is not None and value > hi):
            bound = f"at least {lo}" if hi is None else f"from {lo} to {hi}"
            raise argparse.ArgumentTypeError(f"must be {bound}, got {value}")
        return value

    parse.__name__ = "count"
    return parse


MAX_WORKERS = 256
"""More local processes than this is a typo, not a machine: each one holds a PyBullet copy."""


def add_hand_calibration_flag(parser) -> None:
    """``--hand-calibration``: the shape fit's coefficients for the user's hand."""
    parser.add_argument(
        "--hand-calibration", metavar="FILE.toml",
        help="the shape fit's coefficients for your hand, written by `tactile-bullet calibrate` "
        "(used by every shape fit the command runs)",
    )  # fmt: skip


@contextlib.contextmanager
def hand_calibration_scope(args) -> Iterator[None]:
    """Load ``--hand-calibration`` (a bad file is refused here, before any work) and put its
    coefficients in force for the whole command."""
    path = getattr(args, "hand_calibration", None)
    if not path:
        yield
        return
    from ..perception.shape_model import use_calibration
    from ..realhand.hand_calibration import load

    hand = load(path)
    # what the JSON of identify and evaluate report as their hand_calibration block
    args.hand_calibration_info = {"file": str(path), **hand.to_dict()}
    with use_calibration(hand.calibration):
        yield


def note_hand_calibration(args, doc: dict) -> None:
    """Say in a JSON document which hand calibration its answers used (none: no key)."""
    info = getattr(args, "hand_calibration_info", None)
    if info is not None:
        doc["hand_calibration"] = info
