"""The MuJoCo engine's compiled models (the project's hand + one object), kept on disk between
processes.

Reading a compiled model back (MuJoCo's binary MJB format) is several times faster than
compiling the hand with an object, most of all a torus's 24 convex pieces (docs/performance.md,
"MuJoCo's compiled models across runs"); a process keeps its last few models in memory already
(``mujoco._PROTOTYPES``), so this saves the first grasp of each size in every later process:
a ``generate`` run again, a resumed one, the tour, the tests. Models of a hand given with
``--hand-model`` are not kept (its file may read other files, which no key here covers).

An entry is used only when it passes every check, as the shape fit's grid cache
(``perception/grid_cache.py``): its key (the package version, this file's :data:`FORMAT`,
MuJoCo's version, the hand's MJCF and the sources that build the model) equals the running
code's, it was written for the same object geoms and timestep, and a keyed digest
(HMAC-SHA256 keyed by that key) over the model's bytes matches the one stored beside them (a
``.json`` of the same name).
Anything else (absent, truncated, edited, another version) is compiled again and rewritten
atomically; a cache folder that cannot be written costs speed only. The folder is kept under
:data:`BUDGET` by deleting the least recently used entries. The folder is trusted as
the package itself is: whoever can write it and read this package could forge an entry.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
from collections.abc import Callable, Sequence
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

FORMAT = 1
"""Bumped when an entry's layout changes."""

ENABLED = True
"""Read and write entries; benchmarks turn it off to time a compile."""

_SOURCES = (
    "sim/engines/mujoco.py",
    "sim/engines/mujoco_hand.py",
    "sim/engines/mujoco_objects.py",
    "sim/engines/mujoco_cache.py",
)
"""Modules whose code decides a compiled model (paths inside the package)."""

BUDGET = 256 << 20
"""Bytes of entries kept: past it, the least recently used are deleted down to 3/4 of it (a
randomised sweep's sizes never recur, and a torus's entry is ~0.7 MB)."""
PRUNE_EVERY = 32
"""Entries a process writes between two checks of the folder's size (its first write is
checked too)."""

_LIMIT = 64 << 20
"""Largest entry read (a torus's model is ~0.7 MB)."""


@cache
def code_key() -> str:
    """sha256 over the version, :data:`FORMAT`, MuJoCo's version, the hand's MJCF and the
    sources in :data:`_SOURCES`; "" where any cannot be read (then nothing is cached)."""
    import mujoco

    import tactile_bullet

    from .mujoco_hand import mjcf_path

    root = Path(tactile_bullet.__file__).parent
    digest = hashlib.sha256(
        f"{tactile_bullet.__version__}\n{FORMAT}\n{mujoco.__version__}\n".encode()
    )
    try:
        digest.update(b"mjcf\n" + mjcf_path().read_bytes())
        for name in _SOURCES:
            digest.update(name.encode() + b"\n" + (root / name).read_bytes())
    except OSError:
        return ""
    return digest.hexdigest()


def model_key(geoms: Sequence[Any], timestep: float, phalanx_scale: float) -> str:
    """sha256 of what a model of the project's hand is compiled from besides the code: the
    object's geoms (kind, size, orientation, vertices), the simulation step and the phalanx
    scale."""
    digest = hashlib.sha256(code_key().encode())
    digest.update(np.array([timestep, phalanx_scale], dtype="<f8").tobytes())
    for geom in geoms:
        digest.update(f"|{geom.kind}|".encode())
        for part in (geom.size, geom.quat, geom.vertices):
            values = np.asarray(() if part is None else part, dtype="<f8")
            digest.update(str(values.shape).encode() + values.tobytes())
    return digest.hexdigest()


def entry_path(key: str) -> Path:
    """The entry's model (MuJoCo's binary format); its key and digest lie beside it in a
    ``.json`` of the same name."""
    from ...objects.mesh_cache import cache_dir

    return cache_dir() / "mujoco" / f"{key[:32]}.mjb"


def _digest(mjb: bytes) -> str:
    return hmac.new(bytes.fromhex(code_key()), mjb, hashlib.sha256).hexdigest()


def _read(path: Path, key: str):
    """The model stored at ``path`` for ``key``, or None where any check fails."""
    import mujoco

    try:
        meta = json.loads(path.with_suffix(".json").read_text())
        if not isinstance(meta, dict) or meta.get("key") != key:
            return None
        if path.stat().st_size > _LIMIT:
            return None
        mjb = path.read_bytes()
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    if not hmac.compare_digest(str(meta.get("hmac")), _digest(mjb)):
        return None
    try:  # from the file (3x faster than from memory for a torus's 0.7 MB)
        model = mujoco.MjModel.from_binary_path(str(path))
    except Exception:  # noqa: BLE001 - MuJoCo's own error types; a bad entry is recompiled
        return None
    try:
        os.utime(path)  # used: the last to be pruned
    except OSError:
        pass
    return model


def _write(path: Path, key: str, model) -> None:
    import mujoco

    from ...errors import UsageError
    from ...files import atomic_path

    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    mjb = buffer.tobytes()
    meta = {"key": key, "format": FORMAT, "hmac": _digest(mjb)}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path, "MuJoCo model cache") as tmp:
            tmp.write_bytes(mjb)
        with atomic_path(path.with_suffix(".json"), "MuJoCo model cache") as tmp:
            tmp.write_text(json.dumps(meta))
    except (OSError, UsageError):
        return
    global _WRITTEN
    _WRITTEN += 1
    if _WRITTEN % PRUNE_EVERY == 1:  # a process's first write too: one-grasp commands add up
        prune(path.parent)


_WRITTEN = 0


def prune(folder: Path, budget: int | None = None) -> int:
    """Delete the least recently used entries of ``folder`` while their models hold more than
    ``budget`` bytes (default :data:`BUDGET`), down to 3/4 of it; returns how many were
    deleted. Another process reading one as it goes compiles that model again."""
    budget = BUDGET if budget is None else budget
    entries = []
    for entry in folder.glob("*.mjb"):
        try:
            info = entry.stat()
        except OSError:
            continue
        entries.append((info.st_mtime, info.st_size, entry))
    total = sum(size for _, size, _ in entries)
    if total <= budget:
        return 0
    deleted = 0
    for _, size, entry in sorted(entries):
        if total <= budget * 3 // 4:
            break
        try:
            entry.unlink()
            entry.with_suffix(".json").unlink(missing_ok=True)
        except OSError:
            continue
        total -= size
        deleted += 1
    return deleted


def compiled_model(geoms: Sequence[Any], timestep: float, phalanx_scale: float,
                   compile_model: Callable[[], Any]):  # fmt: skip
    """``compile_model()`` (the hand with ``geoms``), read from the cache where a valid entry
    exists, else compiled and stored."""
    if not ENABLED or not code_key():
        return compile_model()
    key = model_key(geoms, timestep, phalanx_scale)
    path = entry_path(key)
    model = _read(path, key) if path.is_file() else None
    if model is None:
        model = compile_model()
        _write(path, key, model)
    return model
