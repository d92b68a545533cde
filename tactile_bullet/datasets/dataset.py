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

import os
import warnings
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..console import plural
from ..errors import UsageError
from ..records import GraspRecord
from .integrity import (
    DamagedDataset,
    Problem,
    _bytes_problem,
    _decoded_problem,
    _first_line,
    block_tasks,
    check_shards,
    read_manifest,
    read_shard_bytes,
)
from .shards import (
    DECODE_ERRORS,
    MANIFEST,
    NOT_GENERATED,
    SHARD_FILE,
    decode_shard,
    decode_shard_metadata,
)

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
            data = read_shard_bytes(self.path / entry["file"], entry)
        except UsageError as exc:
            return self._damaged(entry, str(exc))
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


def open_dataset(path: str | os.PathLike, allow_partial: bool = False) -> Dataset:
    """The dataset at ``path`` as a :class:`Dataset` (lazy records, metadata, features); see
    :class:`Dataset` for ``allow_partial``. ``tactile_bullet.load_dataset`` gives ``(X, y)``."""
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
        doc = {"data": str(path), "kind": "records", "records": len(loaded.records),
               "engines": engines_of(r.controller.engine for r in loaded.records)}  # fmt: skip
        return {**doc, "ok": not problems, "problems": [p.as_dict() for p in problems]}
    try:
        dataset = Dataset(path, allow_partial=True)
    except UsageError as exc:  # the manifest itself: nothing else can be checked
        problem = Problem(str(path / MANIFEST), str(exc).removeprefix(f"{path / MANIFEST} "))
        return {"data": str(path), "kind": "dataset", "ok": False, "records": 0,
                "problems": [problem.as_dict()]}  # fmt: skip
    listed = sum(e["records"] for e in dataset.shards) + dataset.skipped_records
    readable = 0
    engines = []
    for entry in dataset.shards:
        metas = dataset._decoded(entry, decode_shard_metadata)
        readable += len(metas)
        engines += [m.get("controller", {}).get("engine", "bullet") for m in metas]
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
        "engines": engines_of(engines),
    }


def engines_of(names) -> list[str]:
    """The physics engines that simulated some records, sorted: more than one means the data
    mixes simulators (``verify`` and the reports say so)."""
    return sorted(set(names))


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
            parts.append(f"{plural(missing, 'task')} never generated")
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


RECORDING_SUFFIXES = (".csv", ".parquet", ".pq", ".bag", ".db3", ".mcap")
"""A real hand's recordings (``realhand/recordings.py``): given where records are read, the
error says how to import them."""


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
    from ..records import load_record

    path = Path(path)
    if not path.exists():
        raise UsageError(f"data path {path} does not exist")
    if is_dataset(path):
        dataset = Dataset(path, allow_partial)
        loaded = LoadedRecords(list(dataset.records(full)), dataset.problems)
    else:
        files = [path] if path.is_file() else sorted(path.glob("*.npz"))
        shards = [f.name for f in files if SHARD_FILE.fullmatch(f.name)]
        if shards:  # a dataset that lost its manifest, not a folder of records
            raise UsageError(
                f"{path} holds dataset shards ({shards[0]}, ...) but no {MANIFEST}: without it "
                "they cannot be checked or read; restore it, or generate the dataset again"
            )
        loaded = LoadedRecords([])
        for file in files:
            if not file.is_file():  # a folder, or a FIFO that would block the read forever
                if not allow_partial:
                    raise UsageError(f"{file} is not a regular file")
                loaded.problems.append(Problem(str(file), "not a regular file", 1))
                continue
            try:
                loaded.records.append(load_record(file))
            except DECODE_ERRORS as exc:  # load_record names the file in its UsageErrors
                if isinstance(exc, UsageError):
                    why = str(exc).splitlines()[0]
                else:
                    why = f"{file} is not a readable grasp record ({_first_line(exc)})"
                if file.suffix.lower() in RECORDING_SUFFIXES:
                    why += f"; a recording is read by `tactile-bullet import {file} --out DIR`"
                if not allow_partial:
                    raise UsageError(why) from None
                loaded.problems.append(Problem(str(file), why.replace(f"{file}", "it", 1), 1))
    if not loaded.records and not empty_ok:
        raise UsageError(f"{path} holds no grasp records")
    return loaded
