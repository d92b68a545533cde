"""One shard's bytes: records encoded as plain arrays plus a JSON metadata string (no pickle).

Encoding is deterministic, so a resumed dataset is byte-equal to an uninterrupted one.
"""

from __future__ import annotations

import json
import re
import sys
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import UsageError
from ..files import check_npz_members, write_bytes_atomic
from ..records import RECORD_ARRAYS, RECORD_MEMBER_LIMIT, GraspRecord, record_from_parts

FORMAT = 1
MANIFEST = "manifest.json"
LOCK = ".lock"
"""Held (flock) by the one generate writing the dataset."""
DEFAULT_SHARD_SIZE = 32
SERIES = ("time", "angles", "efforts")
"""Per-record time series: skipped when records are loaded with ``full=False``."""
SHARD_FIELDS = ("block", "file", "records", "failed", "tasks", "sha256")
"""Fields every shard entry of a manifest holds (``bytes``, the shard's size, is optional:
manifests written before it was added lack it)."""
NOT_GENERATED = "not generated (an unfinished run: generate --resume finishes it)"
"""The problem of a block the manifest does not list yet."""
_SHA256 = re.compile(r"[0-9a-f]{64}")
DECODE_ERRORS = (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile,
                  zlib.error, UsageError)  # fmt: skip
"""What numpy and zipfile raise on bytes that are not a whole, valid shard or record."""


# --- writing --------------------------------------------------------------------------------


def fsync_write(path: Path, data: bytes) -> None:
    """Durable atomic write: a reader sees the old file or the new one, even after a crash."""
    write_bytes_atomic(path, data, "dataset file", durable=True)


def encode_shard(parts: Sequence[tuple[Mapping, Mapping[str, np.ndarray]]]) -> bytes:
    """Records' (metadata, arrays) -> the bytes of one .npz shard (arrays concatenated along
    their first axis, with offsets)."""
    import io

    metas = [dict(m) for m, _ in parts]
    arrays: dict[str, np.ndarray] = {}
    keys = list(parts[0][1]) if parts else []
    for key in keys:
        chunks = [np.asarray(a[key]) for _, a in parts]
        lengths = [len(c) for c in chunks]
        arrays[key] = np.concatenate(chunks) if chunks else np.zeros(0)
        arrays[f"{key}__offsets"] = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    buf = io.BytesIO()
    np.savez_compressed(buf, meta=np.array(json.dumps(metas)), **arrays)
    return buf.getvalue()


def decode_shard(source: Path | bytes, full: bool = True) -> list[GraspRecord]:
    """The records of one shard (a file, or its bytes); time series left empty unless
    ``full``."""
    _check_members(source)
    with np.load(_source(source), allow_pickle=False) as data:
        metas = json.loads(str(data["meta"]))
        keys = [k for k in data.files if k != "meta" and not k.endswith("__offsets")]
        if not full:
            keys = [k for k in keys if k not in SERIES]
        columns = {k: (data[k], data[f"{k}__offsets"]) for k in keys}
    records = []
    for i, meta in enumerate(metas):
        arrays = {k: col[off[i] : off[i + 1]] for k, (col, off) in columns.items()}
        if not full:
            n = len(meta["joint_names"])
            arrays.update(time=np.zeros(0), angles=np.zeros((0, n)), efforts=np.zeros((0, n)))
        records.append(record_from_parts(meta, arrays))
    return records


def decode_shard_metadata(source: Path | bytes) -> list[dict]:
    """Only the records' metadata (shape, params, pose, ...): the arrays are not decompressed."""
    _check_members(source)
    with np.load(_source(source), allow_pickle=False) as data:
        return json.loads(str(data["meta"]))


def _check_members(source: Path | bytes) -> None:
    where = "shard" if isinstance(source, bytes) else f"shard {source}"
    # the bound a record file's array has: a default shard (32 grasps) holds a few MB
    check_npz_members(source, where, _is_shard_member, RECORD_MEMBER_LIMIT)


def _is_shard_member(name: str) -> bool:
    return name == "meta" or name.removesuffix("__offsets") in RECORD_ARRAYS


def _source(source: Path | bytes):
    import io

    return io.BytesIO(source) if isinstance(source, bytes) else source


ENGINE_PACKAGES = {"bullet": "pybullet", "mujoco": "mujoco"}
"""The package whose version is each built-in engine's physics: a dataset resumed under
another version of it would hold grasps of two simulators (``generate`` refuses that)."""


def software_versions() -> dict[str, str]:
    """Versions of what shapes a dataset's grasps: this package, Python, the engines, numpy
    and trimesh (``not installed`` for an engine that is not; read from the installed
    packages' metadata, so no engine is imported)."""
    from importlib.metadata import PackageNotFoundError, version

    out = {"tactile_bullet": __version__, "python": sys.version.split()[0]}
    for name in ("pybullet", "mujoco", "numpy", "trimesh"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    return out


SHARD_FILE = re.compile(r"shard-\d{5}\.npz")
"""A shard's file name (:func:`shard_name`)."""
_OWN_FILE = re.compile(r"shard-\d{5}\.npz|\.shard-\d{5}\..*\.tmp\.npz|\.manifest\..*\.tmp\.json")
"""Files a dataset folder holds besides its manifest and lock: shards, and the temporary
files of a killed writer."""


def foreign_in_dataset(folder: Path) -> str | None:
    """The first entry of a dataset ``folder`` this project did not write (a user's notes, a
    web app's files beside a ``manifest.json`` of its own), or None: what ``--force`` may
    replace is a folder of our manifest, shards and lock only."""
    try:
        manifest = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return f"{MANIFEST} (not a dataset manifest)"
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT or not isinstance(
        manifest.get("shards"), list
    ):
        return f"{MANIFEST} (not a dataset manifest)"
    for entry in sorted(folder.iterdir()):
        if entry.name in (MANIFEST, LOCK):
            continue
        if entry.is_symlink() or not entry.is_file() or not _OWN_FILE.fullmatch(entry.name):
            return entry.name
    return None


def shard_name(block: int) -> str:
    return f"shard-{block:05d}.npz"
