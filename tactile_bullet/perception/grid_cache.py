"""The shape fit's grid of predicted angles, kept on disk between processes.

Each family's grid (sizes x offsets x rotations, up to 52k points) is pushed through the
forward model once: about 3 s for the seven built-in families, which every ``tactile-bullet
grasp`` paid again before it printed one answer. The result depends only on this package's
code, so it is stored under the cache folder (``$TACTILE_BULLET_CACHE``, else
``$XDG_CACHE_HOME/tactile-bullet``, else ``~/.cache/tactile-bullet``) in ``shape_fit/``.

A cached grid is used only when it passes every check: its key (the package version, this
file format, and a sha256 of the source files the geometry follows from) equals the running
code's, its grid equals the one asked for, and a keyed digest over its grid and predicted
angles (HMAC-SHA256 keyed by the package's own sources, :func:`code_key`) matches the one
stored beside them. A plain checksum could be recomputed by whoever edited the entry; this one
is not a property of the entry alone. Anything else (absent, truncated, edited, from another
version) is recomputed and rewritten atomically. A cache folder that cannot be written costs
speed only. What the cache trusts: whoever can write it and read this package could still
forge an entry, so the cache folder is trusted as the package itself is (keep it private).
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from collections.abc import Callable
from functools import cache
from pathlib import Path

import numpy as np

FORMAT = 2
"""Bumped when the file's layout changes (2: the digest is keyed, 1's entries are recomputed)."""

_SOURCES = (
    "perception/shape_model.py",
    "perception/shape_fit.py",
    "objects/shapes.py",
    "objects/placement.py",
    "hand.py",
)
"""Modules whose code decides the predicted angles (paths inside the package)."""


@cache
def code_key() -> str:
    """sha256 over the version, :data:`FORMAT` and the sources in :data:`_SOURCES`: any edit
    to the model, the shapes, the placement or the hand invalidates every cached grid. ""
    where the sources cannot be read (an install without .py files): then nothing is cached."""
    import tactile_bullet

    root = Path(tactile_bullet.__file__).parent
    digest = hashlib.sha256(f"{tactile_bullet.__version__}\n{FORMAT}\n".encode())
    try:
        for name in _SOURCES:
            digest.update(name.encode() + b"\n" + (root / name).read_bytes())
    except OSError:
        return ""
    return digest.hexdigest()


def cache_path(family: str) -> Path:
    from ..objects.mesh_cache import cache_dir

    return cache_dir() / "shape_fit" / f"{family}-{code_key()[:16]}.npz"


_MEMBERS = frozenset({"meta", "grid", "geometry"})
"""What :func:`_write` stores; an entry holding anything else is not ours and is recomputed."""


def _checksum(grid: np.ndarray, values: np.ndarray) -> str:
    """HMAC-SHA256 of the grid and its predicted angles, keyed by :func:`code_key` (the
    package's sources): an entry edited with its digest recomputed as a plain sha256 fails."""
    import hmac

    mac = hmac.new(bytes.fromhex(code_key()), digestmod=hashlib.sha256)
    mac.update(np.ascontiguousarray(grid, dtype="<f8").tobytes())
    mac.update(np.ascontiguousarray(values, dtype="<f8").tobytes())
    return mac.hexdigest()


def _read(path: Path, grid: np.ndarray) -> np.ndarray | None:
    """The cached geometry for ``grid``, or None where any check fails."""
    from ..errors import UsageError
    from ..files import check_npz_members

    try:  # members and sizes first, as for every other .npz read (a tampered entry may inflate)
        check_npz_members(path, "shape-fit cache", lambda n: n in _MEMBERS, 256 << 20)
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            stored_grid = np.asarray(data["grid"])
            geometry = np.asarray(data["geometry"], dtype=float)
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile, UsageError):
        return None
    if not isinstance(meta, dict) or meta.get("key") != code_key():
        return None
    if stored_grid.shape != grid.shape or not np.array_equal(stored_grid, grid):
        return None
    if geometry.shape != (len(grid), 3, 4) or meta.get("hmac") != _checksum(grid, geometry):
        return None
    return geometry


def _write(path: Path, grid: np.ndarray, geometry: np.ndarray) -> None:
    from ..errors import UsageError
    from ..files import atomic_path

    meta = {"key": code_key(), "format": FORMAT, "hmac": _checksum(grid, geometry)}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path, "shape-fit cache") as tmp, open(tmp, "wb") as fh:
            np.savez(fh, meta=np.array(json.dumps(meta)), grid=grid, geometry=geometry)
    except (OSError, UsageError):
        pass


def grid_geometry(
    family: str, grid: np.ndarray, compute: Callable[[np.ndarray], np.ndarray]
) -> np.ndarray:
    """``compute(grid)`` for ``family``, read from the cache when a valid entry exists, else
    computed and stored."""
    if not code_key():
        return np.asarray(compute(grid), dtype=float)
    path = cache_path(family)
    cached = _read(path, grid) if path.is_file() else None
    if cached is not None:
        return cached
    geometry = np.asarray(compute(grid), dtype=float)
    _write(path, grid, geometry)
    return geometry
