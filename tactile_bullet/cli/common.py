"""Small helpers shared by the subcommands: JSON output, key=value and vector parsing,
progress bars, output paths."""

from __future__ import annotations

import json
import math
import os
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from ..errors import UsageError


def emit_json(doc: Any) -> None:
    """Print one JSON document on stdout (the ``--json`` contract)."""
    from ..files import json_value

    json.dump(doc, sys.stdout, indent=2, default=json_value)
    sys.stdout.write("\n")


def parse_number(text: str, what: str) -> float:
    try:
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
    """['k=v', ...] -> {k: v} (values left as text; callers convert)."""
    out: dict[str, str] = {}
    for item in items or ():
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise UsageError(f"{what} expects key=value, got {item!r}")
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


def writable_file(path: str | os.PathLike, what: str = "output") -> Path:
    """Check up front that ``path`` can be written, so long work is not lost at the end."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise UsageError(f"{what} path {path} is a directory")
    if not parent.is_dir():
        raise UsageError(f"{what} directory {parent} does not exist")
    if not os.access(parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise UsageError(f"{what} path {path} is not writable")
    return path


def show_progress(json_mode: bool) -> bool:
    """Progress bars only for a person watching: a TTY on stderr and no --json."""
    return not json_mode and sys.stderr.isatty()


def progress(iterable: Iterable, total: int | None, desc: str, enabled: bool) -> Iterable:
    if not enabled:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, unit="grasp", file=sys.stderr)
