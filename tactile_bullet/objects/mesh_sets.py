"""Sets of user meshes in a sweep: the ``[[objects]]`` tables and folders of mesh files."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..errors import UsageError
from .mesh_cache import cache_path
from .mesh_formats import FORMATS
from .meshes import TRIANGLE_BUDGET, MeshSource, check_name, load_source, mesh_source

# --- object sets in sweeps -----------------------------------------------------------------


def files_in(folder: str | os.PathLike) -> list[Path]:
    """The mesh files directly in ``folder``, sorted by name."""
    folder = Path(folder)
    if not folder.is_dir():
        raise UsageError(f"objects folder {folder} does not exist or is not a folder")
    found = sorted(
        p for p in folder.iterdir() if p.is_file() and p.suffix.lower().lstrip(".") in FORMATS
    )
    if not found:
        raise UsageError(f"objects folder {folder} holds no mesh file ({', '.join(FORMATS)})")
    return found


OBJECT_KEYS = ("file", "folder", "name", "unit", "scale", "axis", "sha256", "budget")
"""Keys of an ``[[objects]]`` table that say which mesh; the pose keys are the shapes'."""


def sources_from_table(
    data: Mapping[str, Any], where: str, base: Path | None = None
) -> list[MeshSource]:
    """The mesh sources one ``[[objects]]`` table names: ``file`` (one object, ``name``
    defaults to the file's stem) or ``folder`` (every mesh file in it, named by stem).
    Relative paths are taken from ``base`` (the TOML's folder). A ``sha256`` (as a dataset's
    manifest stores it) must still match the file, or the file be gone and the cache hold it."""
    has_file, has_folder = "file" in data, "folder" in data
    if has_file == has_folder:
        raise UsageError(f"{where}: give exactly one of file = ... or folder = ...")
    if has_folder and "name" in data:
        raise UsageError(f"{where}: name applies to one file, not to a folder")

    def resolved(value) -> Path:
        path = Path(str(value)).expanduser()
        return path if path.is_absolute() or base is None else base / path

    options = {
        "unit": str(data.get("unit", "m")),
        "scale": data.get("scale", 1.0),
        "axis": str(data.get("axis", "auto")),
        "budget": data.get("budget", TRIANGLE_BUDGET),
    }
    if isinstance(options["scale"], bool) or not isinstance(options["scale"], int | float):
        raise UsageError(f"{where}: scale must be a number")
    if isinstance(options["budget"], bool) or not isinstance(options["budget"], int):
        raise UsageError(f"{where}: budget must be an integer")
    try:
        if has_folder:
            return [mesh_source(p, **options) for p in files_in(resolved(data["folder"]))]
        path = resolved(data["file"])
        recorded = data.get("sha256")
        if recorded is not None and not path.exists():
            source = MeshSource(
                str(path), str(recorded), check_name(str(data.get("name", path.stem))),
                options["unit"], float(options["scale"]), options["axis"], int(options["budget"]),
            )  # fmt: skip
            if not cache_path(source).is_file():
                raise UsageError(f"mesh file {path} does not exist and is not in the cache")
            return [source]
        source = mesh_source(path, name=data.get("name"), **options)
        if recorded is not None and recorded != source.sha256:
            raise UsageError(f"mesh file {path} changed since the dataset was made (sha256)")
        return [source]
    except UsageError as exc:
        raise UsageError(f"{where}: {exc}") from None


def check_sources(sources: list[MeshSource]) -> list[MeshSource]:
    """Every object processed (so bad meshes fail before any grasp, and workers find them in
    the cache) and named uniquely (names are the labels)."""
    seen: dict[str, MeshSource] = {}
    for source in sources:
        other = seen.setdefault(source.name, source)
        if other.key != source.key:
            raise UsageError(
                f"two objects are named {source.name!r} ({Path(other.path).name} and "
                f"{Path(source.path).name}): names are labels, give each its own name"
            )
        load_source(source)
    return sources
