"""Datasets on disk: a manifest plus shard files, written so that nothing is ever half-written.

Layout of a dataset directory::

    manifest.json        format, sweep config, seed, software versions, shards, failures
    shard-00000.npz      the records of tasks [0, shard_size), arrays concatenated
    shard-00001.npz      ...

Task ``i`` of the sweep always lands in shard ``i // shard_size``, so a shard is a fixed
block of tasks. A shard is written once its whole block is done (temporary file, fsync,
rename), and the manifest is rewritten the same way right after, listing the shard with its
record count, size and sha256. A run killed at any moment therefore loses at most the blocks
in flight; ``--resume`` checks every listed shard against its checksum and re-runs the blocks
the manifest does not list or whose shard is missing or damaged. Records are deterministic per
task and shards are encoded deterministically, so a resumed dataset is byte-equal to an
uninterrupted one.

Damaged data is never used silently: the manifest is validated when a dataset is opened
(known format, every field present, each block listed once, counts that add up, shard names
plain and inside the folder), each shard is checked against its sha256 when read, and a
problem is an error (:class:`DamagedDataset`, naming the shard) unless the reader passes
``allow_partial=True``, which skips the damaged part and counts what it skipped
(:attr:`Dataset.problems`). :func:`verify` checks a whole dataset at once.

Shards hold no pickles: metadata is a JSON string, arrays are plain numeric arrays.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import sys
import time
import warnings
import zipfile
import zlib
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
SHARD_FIELDS = ("block", "file", "records", "failed", "tasks", "sha256")
"""Fields every shard entry of a manifest holds (``bytes``, the shard's size, is optional:
manifests written before it was added lack it)."""
NOT_GENERATED = "not generated (an unfinished run: generate --resume finishes it)"
"""The problem of a block the manifest does not list yet."""
_SHA256 = re.compile(r"[0-9a-f]{64}")
_DECODE_ERRORS = (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile,
                  zlib.error, UsageError)  # fmt: skip
"""What numpy and zipfile raise on bytes that are not a whole, valid shard or record."""


@dataclass(frozen=True)
class Problem:
    """One damaged or missing part of a dataset (or one unreadable record file)."""

    file: str
    """The shard or record file, with its folder (``ds/shard-00001.npz``)."""
    problem: str
    """What is wrong, in words (``checksum mismatch``, ``missing``, ``not generated``...)."""
    records: int = 0
    """Records the manifest lists for it that cannot be used."""
    tasks: int = 0
    """Sweep tasks of its block that ``generate --resume`` would simulate again."""

    def __str__(self) -> str:
        lost = f" ({self.records} records)" if self.records else ""
        return f"{self.file}: {self.problem}{lost}"

    def as_dict(self) -> dict[str, Any]:
        return {"file": self.file, "problem": self.problem, "records": self.records,
                "tasks": self.tasks}  # fmt: skip


class DamagedDataset(UsageError):
    """A dataset with a damaged, missing or ungenerated part, read without
    ``allow_partial``: the CLI's exit status 2, naming the first problem."""

    def __init__(self, path: Path, problems: Sequence[Problem]) -> None:
        self.problems = list(problems)
        more = len(self.problems) - 1
        others = f" and {more} more (`tactile-bullet verify --data {path}`)" if more else ""
        super().__init__(
            f"damaged dataset: {self.problems[0]}{others}; `generate --resume` simulates it "
            "again, --allow-partial reads the rest"
        )


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


# --- checking a manifest and its shards -----------------------------------------------------


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def manifest_problem(data: Any) -> str | None:
    """Why a manifest cannot describe a dataset at all (unknown format, a required field
    missing or of the wrong kind), or None. Problems of single shard entries are
    :func:`check_shards`'s."""
    if not isinstance(data, dict):
        return "not a JSON object"
    if "format" not in data:
        return "no format field"
    if data["format"] != FORMAT:
        return f"dataset format {data['format']!r} is not supported (this version reads {FORMAT})"
    missing = [k for k in ("config", "tasks", "shards", "failed") if k not in data]
    if missing:
        return f"missing field{'s' * (len(missing) > 1)} {', '.join(missing)}"
    config = data["config"]
    if not isinstance(config, dict) or not isinstance(config.get("sweep"), dict):
        return "config.sweep is missing"
    if not _is_int(config.get("seed")):
        return "config.seed is not an integer"
    if not _is_int(config.get("shard_size")) or config["shard_size"] < 1:
        return "config.shard_size is not a positive integer"
    if not _is_int(data["tasks"]) or data["tasks"] < 0:
        return "tasks is not a count"
    if not isinstance(data["shards"], list) or not isinstance(data["failed"], list):
        return "shards and failed must be lists"
    seen: set[int] = set()
    for item in data["failed"]:
        task = item.get("task") if isinstance(item, dict) else None
        if not _is_int(task) or not 0 <= task < data["tasks"] or task in seen:
            return f"failed lists an invalid or repeated task ({item!r})"
        if not isinstance(item.get("error"), str):
            return f"failed task {task} has no error text"
        seen.add(task)
    return None


def n_blocks(manifest: Mapping[str, Any]) -> int:
    return -(-manifest["tasks"] // manifest["config"]["shard_size"])


def block_tasks(manifest: Mapping[str, Any], block: int) -> range:
    """The sweep's task indices of ``block``."""
    size = manifest["config"]["shard_size"]
    return range(block * size, min((block + 1) * size, manifest["tasks"]))


def _entry_problem(entry: Any, manifest: Mapping[str, Any], failed: Mapping[int, int]) -> str:
    """Why one shard entry is not to be trusted ("" when it is sound)."""
    if not isinstance(entry, dict):
        return "not a JSON object"
    missing = [k for k in SHARD_FIELDS if k not in entry]
    if missing:
        return f"entry without {', '.join(missing)}"
    block, name = entry["block"], entry["file"]
    if not _is_int(block) or not 0 <= block < n_blocks(manifest):
        return f"block {block!r} is not one of the sweep's {n_blocks(manifest)} blocks"
    if not isinstance(name, str) or not _plain_name(name):
        return f"file {name!r} is not a plain file name inside the dataset folder"
    if name != _shard_name(block):
        return f"file {name!r} is not block {block}'s shard ({_shard_name(block)})"
    if not isinstance(entry["sha256"], str) or not _SHA256.fullmatch(entry["sha256"]):
        return "sha256 is not a sha256 digest"
    if "bytes" in entry and (not _is_int(entry["bytes"]) or entry["bytes"] < 0):
        return "bytes is not a size"
    tasks, records, n_failed = entry["tasks"], entry["records"], entry["failed"]
    if not _is_int(records) or not _is_int(n_failed) or records < 0 or n_failed < 0:
        return "records and failed must be counts"
    if not isinstance(tasks, list) or not all(_is_int(t) for t in tasks):
        return "tasks is not a list of task indices"
    own = block_tasks(manifest, block)
    if len(tasks) != records:
        return f"lists {records} records but {len(tasks)} tasks"
    if sorted(set(tasks)) != tasks or not all(t in own for t in tasks):
        return f"tasks are not distinct tasks of block {block} in order"
    if failed.get(block, 0) != n_failed:
        return f"counts {n_failed} failed tasks, the manifest's failed list {failed.get(block, 0)}"
    if records + n_failed != len(own):
        return f"holds {records} records and {n_failed} failures; its block has {len(own)} tasks"
    return ""


def _plain_name(name: str) -> bool:
    """A file name with no folder part: nothing that could point outside the dataset."""
    return (
        bool(name)
        and name not in (".", "..")
        and "/" not in name
        and "\\" not in name
        and "\0" not in name
        and not os.path.isabs(name)
        and Path(name).name == name
    )


def _file_problem(folder: Path, name: str) -> str:
    """Why the shard file ``folder/name`` cannot be read as one ("" when it can): missing,
    not a regular file, or a link that leads outside the dataset folder."""
    path = folder / name
    if path.is_symlink():
        target = Path(os.path.realpath(path))
        if target.parent != Path(os.path.realpath(folder)):
            return f"a link to {target}, outside the dataset folder"
    if not path.exists():
        return "missing"
    if not path.is_file():
        return "not a regular file"
    return ""


def check_shards(folder: Path, manifest: Mapping[str, Any]) -> tuple[list[dict], list[Problem]]:
    """Split a (valid) manifest's shard entries into those to read, in block order, and the
    problems: entries that cannot be trusted, blocks listed twice, shard files missing or
    out of bounds, blocks never generated. Reads no shard; see :func:`shard_problem`."""
    failed: dict[int, int] = {}
    size = manifest["config"]["shard_size"]
    for item in manifest["failed"]:
        failed[item["task"] // size] = failed.get(item["task"] // size, 0) + 1
    good: dict[int, dict] = {}
    bad: list[tuple[int | None, str, str, int]] = []  # block, file, why, records
    for i, entry in enumerate(manifest["shards"]):
        why = _entry_problem(entry, manifest, failed)
        block = entry.get("block") if isinstance(entry, dict) else None
        block = block if _is_int(block) and 0 <= block < n_blocks(manifest) else None
        name = _shard_name(block) if block is not None else f"{MANIFEST} shards[{i}]"
        if not why and block in good:
            bad.append((None, name, "listed twice in the manifest", 0))
            continue
        why = why or _file_problem(folder, name)
        if why:
            records = entry.get("records") if isinstance(entry, dict) else 0
            bad.append((block, name, why, records if _is_int(records) and records > 0 else 0))
            continue
        good[block] = entry
    problems, counted = [], set(good)
    for block, name, why, records in bad:  # a block's tasks counted once, if it is lost
        lost = block is not None and block not in counted
        tasks = len(block_tasks(manifest, block)) if lost else 0
        counted.add(block)
        problems.append(Problem(str(folder / name), why, records, tasks))
    for block in range(n_blocks(manifest)):
        if block not in counted:
            tasks = len(block_tasks(manifest, block))
            problems.append(Problem(str(folder / _shard_name(block)), NOT_GENERATED, 0, tasks))
    return [good[b] for b in sorted(good)], problems


def shard_problem(folder: Path, entry: Mapping[str, Any]) -> str:
    """Why a listed shard's content is not what the manifest says ("" when it is): unreadable,
    wrong size, checksum mismatch, undecodable, or another number of records."""
    try:
        data = (folder / entry["file"]).read_bytes()
    except OSError as exc:
        return f"unreadable ({exc.strerror or exc})"
    return _bytes_problem(entry, data) or _decoded_problem(entry, data, decode_shard_metadata)[0]


def _bytes_problem(entry: Mapping[str, Any], data: bytes) -> str:
    """Why ``data`` are not the bytes the manifest lists for the shard ("" when they are)."""
    if "bytes" in entry and len(data) != entry["bytes"]:
        cut = "truncated" if len(data) < entry["bytes"] else "grown"
        return f"{cut} ({len(data)} bytes, the manifest lists {entry['bytes']})"
    if hashlib.sha256(data).hexdigest() != entry["sha256"]:
        return "checksum mismatch (changed or damaged)"
    return ""


def _decoded_problem(
    entry: Mapping[str, Any], data: bytes, decode: Callable[[bytes], list]
) -> tuple[str, list]:
    """("" or why the shard's bytes do not decode to the records listed, the decoded list)."""
    try:
        decoded = decode(data)
    except _DECODE_ERRORS as exc:
        return f"undecodable ({_first_line(exc)})", []
    if not isinstance(decoded, list) or len(decoded) != entry["records"]:
        count = len(decoded) if isinstance(decoded, list) else "no"
        return f"holds {count} records, the manifest lists {entry['records']}", []
    return "", decoded


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def read_manifest(folder: Path) -> dict[str, Any]:
    """The manifest of the dataset at ``folder``, validated (:func:`manifest_problem`);
    a UsageError naming the file otherwise."""
    path = folder / MANIFEST
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise UsageError(f"{folder} is not a dataset (no {MANIFEST})") from None
    except (OSError, ValueError) as exc:
        raise UsageError(f"{path} is unreadable ({_first_line(exc)})") from None
    why = manifest_problem(data)
    if why:
        raise UsageError(f"{path} is invalid: {why}")
    return data


@dataclass
class _Manifest:
    path: Path
    data: dict[str, Any] = field(default_factory=dict)

    def save(self) -> None:
        text = json.dumps(self.data, indent=1, sort_keys=True)
        _fsync_write(self.path, text.encode())


def _shard_name(block: int) -> str:
    return f"shard-{block:05d}.npz"


def _open_out(
    out: Path, sweep: Sweep, seed: int, shard_size: int, n_tasks: int, resume: bool
) -> tuple[_Manifest, list[Problem]]:
    """Create or reopen the output directory; refuse anything that would mix or lose data.

    On ``resume``, every listed shard is checked (entry, file, size, sha256, record count);
    what fails is dropped from the manifest so that its block is simulated again, and
    returned as the list of problems repaired."""
    config = {"sweep": sweep.to_dict(), "seed": int(seed), "shard_size": int(shard_size)}
    manifest_path = out / MANIFEST
    if manifest_path.exists():
        try:
            data = read_manifest(out)
        except UsageError as exc:
            raise UsageError(f"{exc}; refusing to resume or overwrite it") from None
        existing = data["config"]
        if existing != config:
            differs = [k for k in config if existing.get(k) != config[k]] or ["config"]
            shown = {"sweep": f"sweep {existing.get('sweep', {}).get('name')!r}"}
            detail = ", ".join(shown.get(k, f"{k.replace('_', '-')} {existing.get(k)}")
                               for k in differs)  # fmt: skip
            raise UsageError(f"{out} holds a different dataset ({detail}); choose another --out")
        if data["tasks"] != n_tasks:
            raise UsageError(f"{manifest_path} lists {data['tasks']} tasks, the sweep has "
                             f"{n_tasks}; refusing to resume it")  # fmt: skip
        good, problems = check_shards(out, data)
        if not resume:
            state = _state(good, problems, n_tasks)
            raise UsageError(f"{out} already holds this dataset, {state}; use --resume")
        for entry in list(good):
            why = shard_problem(out, entry)
            if why:
                good.remove(entry)
                problems.append(Problem(str(out / entry["file"]), why, entry["records"],
                                        len(block_tasks(data, entry["block"]))))  # fmt: skip
        for stale in [*out.glob(".shard-*.tmp.npz"), *out.glob(".manifest.*.tmp.json")]:
            stale.unlink(missing_ok=True)  # half-written by the killed run
        manifest = _Manifest(manifest_path, data)
        blocks = {e["block"] for e in good}
        kept_failed = [f for f in data["failed"] if f["task"] // shard_size in blocks]
        if good != data["shards"] or kept_failed != data["failed"]:
            data["shards"], data["failed"] = good, kept_failed
            manifest.save()  # a run killed from here on never lists a damaged shard again
        return manifest, [p for p in problems if p.problem != NOT_GENERATED]
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
    return manifest, []


def _state(good: Sequence[Mapping], problems: Sequence[Problem], n_tasks: int) -> str:
    """'complete', 'partial (done/total tasks)' or 'damaged (...)': what a dataset holds,
    for the refusal to write over it."""
    damaged = [p for p in problems if p.problem != NOT_GENERATED]
    if damaged:
        more = f" and {len(damaged) - 1} more" if len(damaged) > 1 else ""
        return f"damaged ({damaged[0]}{more})"
    done = sum(e["records"] + e["failed"] for e in good)
    return "complete" if done >= n_tasks else f"partial ({done}/{n_tasks} tasks)"


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
    else DEFAULT_SHARD_SIZE. Returns the ``generate --json`` document; its ``repaired``
    lists the shards that ``resume`` found damaged or missing and simulated again.
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
            manifest, repaired = _open_out(out, sweep, seed, shard_size, len(tasks), resume)
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
            with contextlib.closing(results):  # an interrupt stops the workers at once
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
        "repaired": [p.as_dict() for p in repaired],
        "wall_time_s": time.perf_counter() - start,
    }


def _existing_shard_size(out: Path) -> int | None:
    try:
        return int(read_manifest(out)["config"]["shard_size"])
    except UsageError:
        return None  # no dataset there (or an invalid one, refused later)


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
    if (out / LOCK).is_symlink():  # opening it would create or lock a file elsewhere
        raise UsageError(f"{out / LOCK} is a link; refusing to follow it out of the dataset")
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
        "bytes": len(data),
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
    """A dataset directory, read lazily shard by shard (bounded memory).

    The manifest is validated on opening, and each shard is checked against its sha256 as it
    is read. Any problem (an entry that cannot be trusted, a shard missing, damaged or never
    generated) raises :class:`DamagedDataset` naming it, unless ``allow_partial``: then the
    damaged shards are skipped and listed in :attr:`problems`."""

    def __init__(self, path: str | os.PathLike, allow_partial: bool = False) -> None:
        self.path = Path(path)
        self.allow_partial = allow_partial
        self.manifest = read_manifest(self.path)
        self.shards, self.problems = check_shards(self.path, self.manifest)
        """The shard entries to read, and what is wrong so far (grows as shards are read)."""
        if self.problems and not allow_partial:
            raise DamagedDataset(self.path, self.problems)

    def __len__(self) -> int:
        """Records the manifest lists in the shards that are read (before their checksums
        are checked)."""
        return sum(s["records"] for s in self.shards)

    @property
    def failed(self) -> list[dict]:
        return list(self.manifest.get("failed", []))

    @property
    def corrupted(self) -> list[str]:
        """File names of the problems found so far."""
        return [Path(p.file).name for p in self.problems]

    @property
    def skipped_records(self) -> int:
        """Records the manifest lists that were not (or will not be) read."""
        return sum(p.records for p in self.problems)

    def _decoded(self, entry: Mapping, decode: Callable[[bytes], list]) -> list:
        """``decode`` of a shard's bytes once they are the ones the manifest lists; [] for a
        damaged shard when partial reads are allowed."""
        try:
            data = (self.path / entry["file"]).read_bytes()
        except OSError as exc:
            return self._damaged(entry, f"unreadable ({exc.strerror or exc})")
        why = _bytes_problem(entry, data)
        if not why:
            why, decoded = _decoded_problem(entry, data, decode)
        return self._damaged(entry, why) if why else decoded

    def _damaged(self, entry: Mapping, why: str) -> list:
        problem = Problem(str(self.path / entry["file"]), why, entry["records"],
                          len(block_tasks(self.manifest, entry["block"])))  # fmt: skip
        if not self.allow_partial:
            raise DamagedDataset(self.path, [problem])
        if problem.file not in {p.file for p in self.problems}:
            self.problems.append(problem)
        return []

    def _shard(self, entry: Mapping, full: bool) -> list[GraspRecord]:
        return self._decoded(entry, lambda data: decode_shard(data, full))

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
            tasks += entry["tasks"] if shard else []
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


def load_dataset(path: str | os.PathLike, allow_partial: bool = False) -> Dataset:
    """The dataset at ``path``; see :class:`Dataset` for ``allow_partial``."""
    return Dataset(path, allow_partial)


# --- checking and reading any grasp data --------------------------------------------------


def verify(path: str | os.PathLike) -> dict[str, Any]:
    """Check a whole dataset (manifest, every shard's size, checksum and record count), or
    every record of a folder of ``.npz`` records or of one record file. Returns the
    ``verify --json`` document: ``ok``, ``records`` (readable), ``problems`` (each a
    :meth:`Problem.as_dict`), and for a dataset ``listed_records``, ``shards``, ``tasks``,
    ``failed`` (tasks the simulator could not run, which are data, not damage)."""
    path = Path(path)
    if not path.exists():
        raise UsageError(f"data path {path} does not exist")
    if not is_dataset(path):
        loaded = read_records(path, allow_partial=True, full=False, empty_ok=True)
        problems = loaded.problems
        if not loaded.records and not problems:
            raise UsageError(f"{path} is neither a dataset nor a folder of grasp records")
        doc = {"data": str(path), "kind": "records", "records": len(loaded.records)}
        return {**doc, "ok": not problems, "problems": [p.as_dict() for p in problems]}
    try:
        dataset = Dataset(path, allow_partial=True)
    except UsageError as exc:  # the manifest itself: nothing else can be checked
        problem = Problem(str(path / MANIFEST), str(exc).removeprefix(f"{path / MANIFEST} "))
        return {"data": str(path), "kind": "dataset", "ok": False, "records": 0,
                "problems": [problem.as_dict()]}  # fmt: skip
    listed = sum(e["records"] for e in dataset.shards) + dataset.skipped_records
    readable = 0
    for entry in dataset.shards:
        readable += len(dataset._decoded(entry, decode_shard_metadata))
    return {
        "data": str(path),
        "kind": "dataset",
        "ok": not dataset.problems,
        "records": readable,
        "listed_records": listed,
        "shards": len(dataset.manifest["shards"]),
        "tasks": dataset.manifest["tasks"],
        "failed": len(dataset.failed),
        "problems": [p.as_dict() for p in dataset.problems],
    }


@dataclass
class LoadedRecords:
    """Records read from a dataset, a folder of record files or one file, and the problems
    that made a partial read skip some (empty unless ``allow_partial``)."""

    records: list[GraspRecord]
    problems: list[Problem] = field(default_factory=list)

    @property
    def skipped_records(self) -> int:
        return sum(p.records for p in self.problems)

    def summary(self) -> str:
        """One line for the user: what a partial read left out ("" when nothing)."""
        if not self.problems:
            return ""
        missing = sum(p.tasks for p in self.problems if p.problem == NOT_GENERATED)
        damaged = [p for p in self.problems if p.problem != NOT_GENERATED]
        n = self.skipped_records
        parts = [f"{n} record{'s' * (n != 1)} skipped"]
        if damaged:
            parts.append(f"{len(damaged)} damaged part{'s' * (len(damaged) > 1)}: "
                         + "; ".join(str(p) for p in damaged))  # fmt: skip
        if missing:
            parts.append(f"{missing} tasks never generated")
        return f"--allow-partial: {', '.join(parts)}"

    def as_json(self) -> dict[str, Any]:
        """The ``data_skipped`` field of a command's ``--json`` document."""
        return {"records": self.skipped_records,
                "problems": [p.as_dict() for p in self.problems]}  # fmt: skip

    def warn(self) -> None:
        """A Python warning saying what was skipped (for callers of the library)."""
        if self.problems:
            warnings.warn(self.summary(), PartialDataWarning, stacklevel=3)


class PartialDataWarning(UserWarning):
    """Records were skipped because part of the data is damaged (``allow_partial``)."""


def read_records(
    path: str | os.PathLike,
    allow_partial: bool = False,
    full: bool = True,
    empty_ok: bool = False,
) -> LoadedRecords:
    """Every record of a dataset folder (manifest and shards), of a folder of ``.npz`` record
    files, or of one ``.npz`` record file. A damaged part is an error naming it unless
    ``allow_partial``, which skips it and lists it in the result's ``problems``; no records
    at all is an error unless ``empty_ok``."""
    from .records import load_record

    path = Path(path)
    if not path.exists():
        raise UsageError(f"data path {path} does not exist")
    if is_dataset(path):
        dataset = Dataset(path, allow_partial)
        loaded = LoadedRecords(list(dataset.records(full)), dataset.problems)
    else:
        files = [path] if path.is_file() else sorted(path.glob("*.npz"))
        loaded = LoadedRecords([])
        for file in files:
            if not file.is_file():  # a folder, or a FIFO that would block the read forever
                if not allow_partial:
                    raise UsageError(f"{file} is not a regular file")
                loaded.problems.append(Problem(str(file), "not a regular file", 1))
                continue
            try:
                loaded.records.append(load_record(file))
            except _DECODE_ERRORS as exc:  # load_record names the file in its UsageErrors
                why = _first_line(exc)
                if not isinstance(exc, UsageError):
                    why = f"{file} is not a readable grasp record ({why})"
                if not allow_partial:
                    raise UsageError(why) from None
                loaded.problems.append(Problem(str(file), why.replace(f"{file}", "it", 1), 1))
    if not loaded.records and not empty_ok:
        raise UsageError(f"{path} holds no grasp records")
    return loaded
