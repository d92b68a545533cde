"""What the two hand-conversion tools (``independent_hand.py``, ``gym_hand.py``) share: one
way to refuse bad input, to read an MJCF file, and to write the converted model."""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn


def fail(tool: str, message: str) -> NoReturn:
    """One line on stderr and exit status 2, as the CLI answers bad input."""
    print(f"{tool}: {message}", file=sys.stderr)
    raise SystemExit(2)


def read_mjcf(tool: str, path: Path) -> ET.ElementTree:
    """The parsed file, or :func:`fail` naming why it cannot be read."""
    try:
        return ET.parse(path)
    except (OSError, ET.ParseError) as exc:
        fail(tool, f"{path} is not a readable MJCF file: {exc}")


def check_out(tool: str, out: Path, force: bool) -> None:
    """Refuse to overwrite ``out`` unless ``force``: checked before any conversion work."""
    if out.exists() and not force:
        fail(tool, f"{out} exists: name a new file or pass --force")


def write_model(
    tree: ET.ElementTree, out: Path, changes: list[str], check: Callable[[Path], None] | None
) -> None:
    """Write ``tree`` to ``out``, run ``check`` on the written file (it exits on a bad model),
    then list the changes made."""
    tree.write(out, encoding="unicode")
    if check is not None:
        check(out)
    for line in changes:
        print(f"  {line}")
    print(f"wrote {out}")
