"""The disk cache of the built-in shapes' collision pieces: one ``.npz`` per shape and size.

Building a piece needs trimesh, whose import (~0.5 s) was a third of a command-line grasp's own
time on top of the simulation; the pieces of a given shape and size never change for one
version of this package and of trimesh, so the second grasp of a size reads them back
(~1 ms) instead. An entry is keyed by the shape, its sizes, this package's version, the
sha256 of ``shapes.py`` (the code that builds the pieces) and trimesh's version; it is
written atomically and never trusted past a failed check (member names, checksum, array
shapes): a damaged or edited entry reads as a miss and is built again.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..errors import UsageError
from .mesh_cache import cache_dir

MAX_ENTRY_BYTES = 16 << 20
"""A piece of a built-in shape is a few thousand floats; anything far larger is not one."""


class Surface(NamedTuple):
    """An exact (concave) triangle surface: what a shape hands Bullet as a static mesh."""

    vertices: np.ndarray
    faces: np.ndarray


@cache
def _code_key() -> str:
    """What the pieces depend on besides the sizes: this package and trimesh, by version, and
    the source of the functions that build them."""
    from importlib.metadata import PackageNotFoundError, version

    from .. import __version__

    try:
        trimesh_version = version("trimesh")
    except PackageNotFoundError:
        trimesh_version = "absent"
    source = hashlib.sha256((Path(__file__).parent / "shapes.py").read_bytes()).hexdigest()
    return f"{__version__}:{trimesh_version}:{source}"


def entry_path(name: str, params: dict[str, float]) -> Path:
    """The cache file of shape ``name`` at ``params``."""
    text = json.dumps({"shape": name, "params": {k: repr(float(v)) for k, v in
                                                 sorted(params.items())},
                       "code": _code_key()}, sort_keys=True)  # fmt: skip
    return cache_dir() / "pieces" / f"{name}-{hashlib.sha256(text.encode()).hexdigest()[:32]}.npz"


def _as_arrays(pieces: list) -> dict[str, np.ndarray]:
    arrays = {}
    for i, piece in enumerate(pieces):
        if hasattr(piece, "faces"):
            arrays[f"v{i}"] = np.asarray(piece.vertices, dtype=float)
            arrays[f"f{i}"] = np.asarray(piece.faces, dtype=np.int64)
        else:
            arrays[f"v{i}"] = np.asarray(piece, dtype=float)
    return arrays


def _from_arrays(arrays: dict[str, np.ndarray]) -> list[np.ndarray | Surface]:
    count = sum(1 for k in arrays if k.startswith("v"))
    if count < 1 or set(arrays) - {f"{c}{i}" for c in "vf" for i in range(count)}:
        raise ValueError("unexpected members")
    out: list[np.ndarray | Surface] = []
    for i in range(count):
        v = arrays[f"v{i}"]
        if v.dtype != np.float64 or v.ndim != 2 or v.shape[1] != 3 or len(v) < 4 \
                or not np.all(np.isfinite(v)):  # fmt: skip
            raise ValueError("not a vertex array")
        f = arrays.get(f"f{i}")
        if f is None:
            out.append(v)
            continue
        if f.dtype != np.int64 or f.ndim != 2 or f.shape[1] != 3 or len(f) < 4 \
                or f.min() < 0 or f.max() >= len(v):  # fmt: skip
            raise ValueError("not a face array")
        out.append(Surface(v, f))
    return out


def _checksum(arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for key in sorted(arrays):
        arr = np.ascontiguousarray(arrays[key])
        h.update(f"{key}:{arr.dtype.str}:{arr.shape}".encode())
        h.update(arr.tobytes())
    return h.hexdigest()


def read_entry(path: Path) -> list[np.ndarray | Surface] | None:
    """The pieces stored at ``path``, or None where it is absent or fails any check."""
    if not path.is_file():
        return None
    from ..files import check_npz_members

    try:
        check_npz_members(path, str(path), lambda n: True, MAX_ENTRY_BYTES)
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {k: np.asarray(data[k]) for k in data.files if k != "meta"}
        if meta.get("checksum") != _checksum(arrays):
            return None
        return _from_arrays(arrays)
    except Exception:  # noqa: BLE001 - any failure of a cache entry means: build again
        return None


def write_entry(path: Path, pieces: list) -> None:
    """Store ``pieces`` atomically; a cache that cannot be written costs speed only."""
    from ..files import atomic_path

    arrays = _as_arrays(pieces)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path, "piece cache") as tmp, open(tmp, "wb") as fh:
            np.savez(fh, meta=np.array(json.dumps({"checksum": _checksum(arrays)})), **arrays)
    except (OSError, UsageError):
        pass


def cached(name: str, build: Callable[..., list]) -> Callable[..., list]:
    """``build`` (a shape's pieces function) read from the disk cache where it holds the
    size, else built and stored. Concave pieces come back as :class:`Surface` either way."""

    def pieces(**params: Any) -> list[np.ndarray | Surface]:
        path = entry_path(name, params)
        hit = read_entry(path)
        if hit is not None:
            return hit
        built = _from_arrays(_as_arrays(build(**params)))
        write_entry(path, built)
        return built

    pieces.__doc__ = build.__doc__
    pieces.__wrapped__ = build  # type: ignore[attr-defined]
    return pieces
