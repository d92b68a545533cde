"""Checking a dataset's manifest and its shards before any of it is used.

The manifest is validated (known format, every field present, each block listed once, counts
that add up, shard names plain and inside the folder) and each shard against its sha256; a
problem is a :class:`Problem` naming the shard, raised as :class:`DamagedDataset` unless the
reader allows partial data.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..console import plural
from ..errors import UsageError
from ..files import INPUT_LIMITS, input_path, read_input_text
from .shards import (
    _SHA256,
    DECODE_ERRORS,
    FORMAT,
    MANIFEST,
    NOT_GENERATED,
    SHARD_FIELDS,
    decode_shard_metadata,
    shard_name,
)
from .sweeps import MAX_GRASPS


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
        lost = f" ({plural(self.records, 'record')})" if self.records else ""
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
    if data["tasks"] > MAX_GRASPS:  # bounded before any loop over blocks or tasks
        return f"tasks {data['tasks']:,} is over the {MAX_GRASPS:,} a dataset may hold"
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
    if name != shard_name(block):
        return f"file {name!r} is not block {block}'s shard ({shard_name(block)})"
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
        return f"lists {plural(records, 'record')} but {plural(len(tasks), 'task')}"
    if sorted(set(tasks)) != tasks or not all(t in own for t in tasks):
        return f"tasks are not distinct tasks of block {block} in order"
    if failed.get(block, 0) != n_failed:
        return f"counts {n_failed} failed tasks, the manifest's failed list {failed.get(block, 0)}"
    if records + n_failed != len(own):
        return (f"holds {plural(records, 'record')} and {plural(n_failed, 'failure')}; its "
                f"block has {plural(len(own), 'task')}")  # fmt: skip
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
        name = shard_name(block) if block is not None else f"{MANIFEST} shards[{i}]"
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
            problems.append(Problem(str(folder / shard_name(block)), NOT_GENERATED, 0, tasks))
    return [good[b] for b in sorted(good)], problems


def shard_problem(folder: Path, entry: Mapping[str, Any]) -> str:
    """Why a listed shard's content is not what the manifest says ("" when it is): unreadable,
    wrong size, checksum mismatch, undecodable, or another number of records."""
    try:
        data = read_shard_bytes(folder / entry["file"], entry)
    except UsageError as exc:
        return str(exc)
    return _bytes_problem(entry, data) or _decoded_problem(entry, data, decode_shard_metadata)[0]


def read_shard_bytes(path: Path, entry: Mapping[str, Any]) -> bytes:
    """A listed shard's bytes, never more than a little over the size its entry lists (or the
    record-file limit): a FIFO, device or grown file is refused with why, not read whole."""
    limit = entry["bytes"] if _is_int(entry.get("bytes")) else INPUT_LIMITS["record file"]
    try:
        input_path(path, "shard", min(limit + 1, INPUT_LIMITS["record file"]))
        return path.read_bytes()
    except UsageError as exc:
        why = str(exc).removeprefix(f"shard {path} ").removeprefix("is ")
        raise UsageError(f"unreadable ({why})") from None
    except OSError as exc:
        raise UsageError(f"unreadable ({exc.strerror or exc})") from None


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
    except DECODE_ERRORS as exc:
        return f"undecodable ({_first_line(exc)})", []
    if not isinstance(decoded, list) or len(decoded) != entry["records"]:
        held = plural(len(decoded), "record") if isinstance(decoded, list) else "no records"
        return f"holds {held}, the manifest lists {entry['records']}", []
    return "", decoded


def _first_line(exc: BaseException) -> str:
    from ..files import load_failure

    return load_failure(exc)


def read_manifest(folder: Path) -> dict[str, Any]:
    """The manifest of the dataset at ``folder``, validated (:func:`manifest_problem`);
    a UsageError naming the file otherwise."""
    path = folder / MANIFEST
    if not path.exists() and not path.is_symlink():
        raise UsageError(f"{folder} is not a dataset (no {MANIFEST})")
    try:
        data = json.loads(read_input_text(path, "manifest"))
    except (OSError, ValueError) as exc:
        raise UsageError(f"{path} is unreadable ({_first_line(exc)})") from None
    why = manifest_problem(data)
    if why:
        raise UsageError(f"{path} is invalid: {why}")
    return data
