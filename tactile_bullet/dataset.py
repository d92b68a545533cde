"""Datasets on disk: a manifest plus shard files, written so that nothing is ever half-written.

Layout of a dataset directory::

    manifest.json        format, sweep config, seed, software versions, shards, failures
    shard-00000.npz      the records of tasks [0, shard_size), arrays concatenated
    shard-00001.npz      ...

Task ``i`` of the sweep always lands in shard ``i // shard_size``, so a shard is a fixed
block of tasks. A shard is written once its whole block is done (temporary file, fsync,
rename), and the manifest is rewritten the same way right after, listing the shard with its
record count and sha256. A run killed at any moment therefore loses at most the blocks in
flight; ``--resume`` re-runs exactly the blocks the manifest does not list. Records are
deterministic per task, so a resumed dataset equals an uninterrupted one.

Shards hold no pickles: metadata is a JSON string, arrays are plain numeric arrays.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__
from .errors import UsageError
from .files import write_bytes_atomic
from .records import GraspRecord, record_from_parts
from .sweeps import Sweep

FORMAT = 1
MANIFEST = "manifest.json"
LOCK = ".lock"
"""Held (flock) by the one generate writing the dataset."""
DEFAULT_SHARD_SIZE = 32
SERIES = ("time", "angles", "efforts")
"""Per-record time series: skipped when records are loaded with ``full=False``."""


# --- writing --------------------------------------------------------------------------------


def _fsync_write(path: Path, data: bytes) -> None:
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
    with np.load(_source(source), allow_pickle=False) as data:
        return json.loads(str(data["meta"]))


def _source(source: Path | bytes):
    import io

    return io.BytesIO(source) if isinstance(source, bytes) else source


def software_versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    out = {"tactile_bullet": __version__, "python": sys.version.split()[0]}
    for name in ("pybullet", "numpy", "trimesh"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "unknown"
    return out


@dataclass
class _Manifest:
    path: Path
    data: dict[str, Any] = field(default_factory=dict)

    def save(self) -> None:
        text = json.dumps(self.data, indent=1, sort_keys=True)
        _fsync_write(self.path, text.encode())


def _shard_name(block: int) -> str:
    return f"shard-{block:05d}.npz"


def _open_out(out: Path, sweep: Sweep, seed: int, shard_size: int, n_tasks: int, resume: bool):
    """Create or reopen the output directory; refuse anything that would mix or lose data."""
    config = {"sweep": sweep.to_dict(), "seed": int(seed), "shard_size": int(shard_size)}
    manifest_path = out / MANIFEST
    if manifest_path.exists():
        try:
            data = json.loads(manifest_path.read_text())
            existing = data["config"]
        except (OSError, ValueError, KeyError):
            raise UsageError(
                f"{out} holds an unreadable manifest; refusing to overwrite it"
            ) from None
        if existing != config:
            differs = [k for k in config if existing.get(k) != config[k]] or ["config"]
            shown = {"sweep": f"sweep {existing.get('sweep', {}).get('name')!r}"}
            detail = ", ".join(shown.get(k, f"{k.replace('_', '-')} {existing.get(k)}")
                               for k in differs)  # fmt: skip
            raise UsageError(f"{out} holds a different dataset ({detail}); choose another --out")
        done = sum(s["records"] + s["failed"] for s in data["shards"])
        if not resume:
            state = "complete" if done >= n_tasks else f"partial ({done}/{n_tasks} tasks)"
            raise UsageError(f"{out} already holds this dataset, {state}; use --resume")
        for stale in [*out.glob(".shard-*.tmp.npz"), *out.glob(".manifest.*.tmp.json")]:
            stale.unlink(missing_ok=True)  # half-written by the killed run
        return _Manifest(manifest_path, data)
    if any(p.name != LOCK for p in out.iterdir()):
        raise UsageError(f"--out {out} exists and is not an empty directory or a dataset")
    if not os.access(out, os.W_OK):
        raise UsageError(f"--out {out} is not writable")
    manifest = _Manifest(
        manifest_path,
        {
            "format": FORMAT,
            "config": config,
            "tasks": n_tasks,
            "software": software_versions(),
            "shards": [],
            "failed": [],
        },
    )
    manifest.save()
    return manifest


def generate(
    sweep: Sweep,
    out: str | os.PathLike,
    *,
    workers: int = 1,
    cluster: str | None = None,
    resume: bool = False,
    seed: int = 0,
    shard_size: int | None = None,
    progress: bool = False,
    task_fn: Callable | None = None,
) -> dict[str, Any]:
    """Simulate every task of ``sweep`` into the dataset directory ``out``.

    ``workers`` local processes (0: in this process, no crash isolation), or the Dask
    scheduler at ``cluster``. ``shard_size`` None: the existing dataset's (on --resume),
    else DEFAULT_SHARD_SIZE. Returns the ``generate --json`` document.
    """
    from . import executors

    if shard_size is None:
        shard_size = _existing_shard_size(Path(out)) or DEFAULT_SHARD_SIZE
    if workers < 0:
        raise UsageError(f"--workers must be >= 0, got {workers}")
    if shard_size < 1:
        raise UsageError(f"--shard-size must be >= 1, got {shard_size}")
    start = time.perf_counter()
    out = Path(out)
    tasks = sweep.tasks(seed)
    client = executors.connect_dask(cluster) if cluster else None
    try:
        _make_out(out)
        with _writer_lock(out):
            manifest = _open_out(out, sweep, seed, shard_size, len(tasks), resume)
            blocks_done = {s["block"] for s in manifest.data["shards"]}
            todo = [t for t in tasks if t.index // shard_size not in blocks_done]
            task_fn = task_fn or executors.run_task
            if client is not None:
                results = executors.run_dask(todo, client, task_fn)
                client = None  # run_dask closes it
            elif workers == 0:
                results = ((t.index, task_fn(t)) for t in todo)
            else:
                results = executors.run_local(todo, workers, task_fn)
            _fill(out, manifest, todo, results, shard_size, progress)
    finally:
        if client is not None:
            client.close()
    shards = manifest.data["shards"]
    return {
        "out": str(out),
        "records": sum(s["records"] for s in shards),
        "shards": len(shards),
        "failed": len(manifest.data["failed"]),
        "wall_time_s": time.perf_counter() - start,
    }


def _existing_shard_size(out: Path) -> int | None:
    try:
        return int(json.loads((out / MANIFEST).read_text())["config"]["shard_size"])
    except (OSError, ValueError, KeyError, TypeError):
        return None  # no dataset there (or an unreadable one, refused later)


def _make_out(out: Path) -> None:
    """Create ``out`` if needed; refuse (touching nothing) a file or a folder of other data."""
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out} exists and is not a directory")
    if out.is_dir() and not (out / MANIFEST).exists():
        if any(p.name != LOCK for p in out.iterdir()):
            raise UsageError(f"--out {out} exists and is not an empty directory or a dataset")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"cannot create --out {out}: {exc.strerror or exc}") from None


@contextlib.contextmanager
def _writer_lock(out: Path) -> Iterator[None]:
    """One writer per dataset: a second generate on the same --out (a --resume started while
    the first still runs) would rewrite the manifest under it. The OS drops the lock when its
    process dies, so a killed run never blocks the --resume that follows."""
    try:
        import fcntl
    except ImportError:  # Windows: no advisory locks; one writer is then the user's care
        yield
        return
    try:
        handle = open(out / LOCK, "a")  # noqa: SIM115 - held until the with block ends
    except OSError as exc:
        raise UsageError(f"--out {out} is not writable ({exc.strerror or exc})") from None
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise UsageError(f"another generate is writing to {out}; let it finish") from None
        yield


def _fill(out, manifest, todo, results, shard_size: int, progress: bool) -> None:
    """Collect outcomes as they come and write each block's shard once the block is whole."""
    block_sizes: dict[int, int] = {}
    for t in todo:
        block_sizes[t.index // shard_size] = block_sizes.get(t.index // shard_size, 0) + 1
    buffers: dict[int, dict[int, Any]] = {b: {} for b in block_sizes}
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), desc="grasps", unit="grasp", file=sys.stderr)
    for index, outcome in results:
        block = index // shard_size
        buffers[block][index] = outcome
        if bar is not None:
            bar.update(1)
        if len(buffers[block]) == block_sizes[block]:
            _write_block(out, manifest, block, buffers.pop(block))
    if bar is not None:
        bar.close()


def _write_block(out: Path, manifest: _Manifest, block: int, outcomes: Mapping[int, Any]):
    ok = [(i, o) for i, o in sorted(outcomes.items()) if not isinstance(o, str)]
    failed = [{"task": i, "error": o} for i, o in sorted(outcomes.items()) if isinstance(o, str)]
    name = _shard_name(block)
    data = encode_shard([o for _, o in ok])
    _fsync_write(out / name, data)
    entry = {
        "block": block,
        "file": name,
        "records": len(ok),
        "failed": len(failed),
        "tasks": [i for i, _ in ok],
        "sha256": hashlib.sha256(data).hexdigest(),
    }
    manifest.data["shards"] = sorted(
        [s for s in manifest.data["shards"] if s["block"] != block] + [entry],
        key=lambda s: s["block"],
    )
    manifest.data["failed"] = sorted(
        [
            f
            for f in manifest.data["failed"]
            if f["task"] // manifest.data["config"]["shard_size"] != block
        ]
        + failed,
        key=lambda f: f["task"],
    )
    manifest.save()


# --- reading --------------------------------------------------------------------------------


def is_dataset(path: str | os.PathLike) -> bool:
    return (Path(path) / MANIFEST).is_file()


class Dataset:
    """A dataset directory, read lazily shard by shard (bounded memory)."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        try:
            self.manifest = json.loads((self.path / MANIFEST).read_text())
            self.shards = list(self.manifest["shards"])
            if self.manifest.get("format") != FORMAT:
                raise UsageError(f"{self.path}: dataset format {self.manifest.get('format')} "
                                 f"is not supported (this version reads {FORMAT})")  # fmt: skip
        except FileNotFoundError:
            raise UsageError(f"{self.path} is not a dataset (no {MANIFEST})") from None
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise UsageError(f"{self.path}/{MANIFEST} is unreadable ({exc})") from None
        self.corrupted: list[str] = []

    def __len__(self) -> int:
        return sum(s["records"] for s in self.shards)

    @property
    def failed(self) -> list[dict]:
        return list(self.manifest.get("failed", []))

    def _bytes(self, entry: Mapping) -> bytes | None:
        """A shard's bytes once its checksum matches the manifest's; None (and a warning
        naming the file) otherwise."""
        try:
            data = (self.path / entry["file"]).read_bytes()
        except OSError as exc:
            return self._bad(entry, f"unreadable ({exc.strerror or exc})")
        if hashlib.sha256(data).hexdigest() != entry["sha256"]:
            return self._bad(entry, "checksum mismatch")
        return data

    def _decoded(self, entry: Mapping, decode: Callable[[bytes], list]) -> list:
        data = self._bytes(entry)
        if data is None:
            return []
        try:
            return decode(data)
        except (OSError, ValueError, KeyError, TypeError, UsageError) as exc:
            self._bad(entry, f"undecodable ({exc})")
            return []

    def _shard(self, entry: Mapping, full: bool) -> list[GraspRecord]:
        return self._decoded(entry, lambda data: decode_shard(data, full))

    def _bad(self, entry: Mapping, why: str) -> None:
        message = f"{entry['file']}: {why}; its {entry['records']} records are skipped"
        if entry["file"] not in self.corrupted:
            self.corrupted.append(entry["file"])
            print(f"tactile-bullet: warning: {self.path}/{message}", file=sys.stderr)

    def records(self, full: bool = False) -> Iterator[GraspRecord]:
        """Records in task order; time series only when ``full`` (they dominate memory)."""
        for entry in self.shards:
            yield from self._shard(entry, full)

    def __iter__(self) -> Iterator[GraspRecord]:
        return self.records(full=True)

    def features(self, descriptor, full: bool = False) -> np.ndarray:
        """(n, d) features of every record, computed shard by shard so that only one shard's
        records are in memory; ``full`` for descriptors that read the time series."""
        blocks = []
        for entry in self.shards:
            recs = self._shard(entry, full=full)
            if recs:
                blocks.append(np.asarray(descriptor.transform(recs), float))
        return np.vstack(blocks) if blocks else np.zeros((0, 0))

    def labels(self) -> np.ndarray:
        """(n,) shape names, the classes to learn, in the order of ``records()``."""
        return self.metadata()["shape"]

    def metadata(self) -> dict[str, Any]:
        """Per-record metadata as arrays, in the order of ``records()``, for binning results
        (accuracy by size, position, rotation) without decompressing any time series:
        ``shape`` (n,) str, ``offset`` (n, 3) m, ``rotation`` (n,) rad, ``seed`` (n,),
        ``params`` {name: (n,) float}, NaN where a record's shape has no such parameter;
        ``task`` (n,) the sweep's task index (seeds are 32-bit and may repeat in big sweeps)."""
        metas, tasks = [], []
        for entry in self.shards:
            shard = self._decoded(entry, decode_shard_metadata)
            metas += shard
            tasks += entry["tasks"] if len(entry["tasks"]) == len(shard) else [-1] * len(shard)
        names = sorted({k for m in metas for k in m["params"]})
        return {
            "shape": np.array([m["shape"] for m in metas], dtype=str),
            "offset": np.array([m["pose"]["offset"] for m in metas], float).reshape(-1, 3),
            "rotation": np.array([m["pose"]["rotation"] for m in metas], float),
            "seed": np.array([m["seed"] for m in metas], np.int64),
            "task": np.array(tasks, np.int64),
            "params": {
                k: np.array([m["params"].get(k, np.nan) for m in metas], float) for k in names
            },
        }


def load_dataset(path: str | os.PathLike) -> Dataset:
    return Dataset(path)
