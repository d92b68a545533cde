"""The disk cache of processed meshes: one ``.npz`` per file content and processing options,
so later loads, worker processes and re-simulations of saved records skip the processing.

An entry holds the arrays processing produced (:data:`CACHE_ARRAYS`) and its metadata (the
mesh's source, what processing found, a checksum over both). It is written atomically (parallel
workers may race, never half-write) and never trusted past a failed check: an entry that is
absent, damaged, edited or unsound reads as a miss, and the mesh is processed again. The
entries are keyed and filled by :mod:`~tactile_bullet.objects.meshes` (a ``MeshSource`` names
the entry; ``MeshInfo`` is stored as a plain dict).
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import UsageError

CACHE_ENV = "TACTILE_BULLET_CACHE"
"""Overrides the cache folder (default: $XDG_CACHE_HOME/tactile-bullet, ~/.cache/...)."""


def cache_dir() -> Path:
    """$TACTILE_BULLET_CACHE, else $XDG_CACHE_HOME/tactile-bullet, else ~/.cache/tactile-bullet
    (the ``meshes`` folder inside holds one .npz per processed mesh)."""
    override = os.environ.get(CACHE_ENV)
    if override:
        return Path(override)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "tactile-bullet"


def cache_path(source) -> Path:
    """The entry of a ``MeshSource`` (its ``key``: file content and options)."""
    return cache_dir() / "meshes" / f"{source.key}.npz"


CACHE_ARRAYS = (
    "vertices", "faces", "collision_vertices", "collision_faces",
    "profile_x", "profile_r", "profile_reach",
)  # fmt: skip


def write_cache(source, info, arrays: Mapping[str, np.ndarray]) -> None:
    """Store a processed mesh: its ``MeshSource``, ``MeshInfo`` (a dataclass) and arrays.
    Atomic write (temporary file, rename): parallel workers may race, never half-write. A
    cache that cannot be written costs speed, not results: skipped."""
    from ..files import atomic_path

    path = cache_path(source)
    meta = {"source": source.to_dict(), "info": asdict(info)}
    meta["checksum"] = _cache_checksum(meta, arrays)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path, "mesh cache") as tmp, open(tmp, "wb") as fh:
            np.savez(fh, meta=np.array(json.dumps(meta)), **{k: arrays[k] for k in CACHE_ARRAYS})
    except (OSError, UsageError):
        pass


def read_cache(source) -> tuple[dict[str, Any], dict[str, np.ndarray]] | None:
    """The entry of ``source`` as (what processing found, as a dict; the arrays), or None if
    absent, unreadable, of another file content, tampered with or unsound (then it is processed
    again and the damaged entry overwritten: a cache is never trusted past a failed check)."""
    path = cache_path(source)
    if not path.is_file():
        return None
    from ..files import check_npz_members

    try:  # an entry holds a 20k-triangle mesh (~1 MB): anything far larger is not one
        check_npz_members(path, str(path), lambda n: n == "meta" or n in CACHE_ARRAYS, 64 << 20)
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {k: np.asarray(data[k]) for k in data.files if k != "meta"}
        if meta["source"]["sha256"] != source.sha256 or sorted(arrays) != sorted(CACHE_ARRAYS):
            return None
        if meta.get("checksum") != _cache_checksum(meta, arrays):  # tampered or damaged
            return None
        info = dict(meta["info"])
        if not _cache_arrays_sound(arrays, bool(info["convex"])):
            return None
        return info, arrays
    except Exception:  # noqa: BLE001 - any failure of a cache entry means: process again
        return None


def _cache_checksum(meta: Mapping[str, Any], arrays: Mapping[str, np.ndarray]) -> str:
    """sha256 over the entry's metadata (less the checksum) and every array's dtype, shape
    and bytes: an entry edited by hand or damaged on disk no longer matches."""
    h = hashlib.sha256(json.dumps({k: v for k, v in meta.items() if k != "checksum"},
                                  sort_keys=True).encode())  # fmt: skip
    for key in CACHE_ARRAYS:
        arr = np.ascontiguousarray(arrays[key])
        h.update(f"{key}:{arr.dtype.str}:{arr.shape}".encode())
        h.update(arr.tobytes())
    return h.hexdigest()


def _cache_arrays_sound(arrays: Mapping[str, np.ndarray], convex: bool) -> bool:
    """The shapes and ranges a processed mesh always has (an entry written by an older or
    broken version may carry a valid checksum and still not be one)."""
    for prefix in ("", "collision_"):
        v, f = arrays[f"{prefix}vertices"], arrays[f"{prefix}faces"]
        if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4 or f.ndim != 2 or f.shape[1] != 3:
            return False
        if not convex and len(f) == 0:
            return False
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            return False
    px, pr, reach = arrays["profile_x"], arrays["profile_r"], arrays["profile_reach"]
    if px.ndim != 1 or len(px) < 2 or pr.shape != px.shape or reach.shape != px.shape:
        return False
    if np.any(np.diff(px) <= 0) or np.any(pr < 0):
        return False
    return all(np.all(np.isfinite(arrays[k])) for k in CACHE_ARRAYS)
