"""Writing a dataset: a sweep's grasps run in blocks, each block written atomically as a shard.

A run killed at any moment loses at most the blocks in flight; ``resume`` re-runs the blocks
the manifest does not list or whose shard is missing or damaged. One writer at a time (a lock
file).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from ..errors import UsageError
from ..records import ControllerSettings
from .integrity import Problem, block_tasks, check_shards, read_manifest, shard_problem
from .shards import (
    DEFAULT_SHARD_SIZE,
    ENGINE_PACKAGES,
    FORMAT,
    LOCK,
    MANIFEST,
    NOT_GENERATED,
    encode_shard,
    fsync_write,
    shard_name,
    software_versions,
)
from .sweeps import Sweep


@dataclass
class _Manifest:
    path: Path
    data: dict[str, Any] = field(default_factory=dict)

    def save(self) -> None:
        text = json.dumps(self.data, indent=1, sort_keys=True)
        fsync_write(self.path, text.encode())


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
        _same_hand(out, existing, config, data.get("hand_model_files"))
        if existing != config:
            differs = [k for k in config if existing.get(k) != config[k]] or ["config"]
            shown = {"sweep": _sweep_difference(existing.get("sweep", {}), config["sweep"])}
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
            **_hand_files(sweep),
            "shards": [],
            "failed": [],
        },
    )
    manifest.save()
    return manifest, []


def _hand_files(sweep: Sweep) -> dict[str, Any]:
    """``{"hand_model_files": {name: sha256}}``: each file of the sweep's hand model, kept in
    the manifest so that ``--resume`` can name the one that changed (none: nothing)."""
    if sweep.controller.hand_model is None:
        return {}
    from ..sim.engines.mujoco_hand import model_digest

    return {"hand_model_files": model_digest(sweep.controller.hand_model)[1]}


def _same_hand(out: Path, existing: Mapping, config: Mapping, files: Mapping | None) -> None:
    """Refuse to resume a dataset whose hand model changed since it was started (the model
    file, or a file it includes or references), naming what changed: the rest of its grasps
    would come from another hand."""
    old = existing.get("sweep", {}).get("controller", {})
    new = config["sweep"].get("controller", {})
    if old.get("hand_model") != new.get("hand_model") or new.get("hand_model") is None:
        return
    if old.get("hand_model_digest") == new.get("hand_model_digest"):
        return
    model = new["hand_model"]
    if old.get("hand_model_digest") is None:
        raise UsageError(
            f"{out} was started with hand model {model} before datasets kept its content "
            "digest: whether it changed since cannot be told; choose another --out"
        )
    from ..sim.engines.mujoco_hand import model_digest

    now = model_digest(model)[1]
    files = dict(files or {})
    changed = sorted(n for n in set(now) | set(files) if now.get(n) != files.get(n))
    named = ", ".join(changed[:3]) + (f" and {len(changed) - 3} more" if len(changed) > 3 else "")
    raise UsageError(
        f"{out} was made with another hand: hand model {model} changed since the dataset was "
        f"started ({named or 'its content'}); resuming would mix two hands - choose another "
        "--out, or restore the model"
    )


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
    if resume and not (out / MANIFEST).exists():  # a mistyped --out: not a whole new run
        raise UsageError(f"--resume: {out} holds no dataset to resume (no {MANIFEST})")
    tasks = sweep.tasks(seed)
    client = executors.connect_dask(cluster) if cluster else None
    if client is not None:
        executors.check_worker_engines(client)
    try:
        _make_out(out)
        with _writer_lock(out):
            manifest, repaired = _open_out(out, sweep, seed, shard_size, len(tasks), resume)
            blocks_done = {s["block"] for s in manifest.data["shards"]}
            todo = [t for t in tasks if t.index // shard_size not in blocks_done]
            _same_engines(out, manifest.data.get("software", {}), todo)
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


_DEFAULT_CONTROLLER = {f.name: f.default for f in fields(ControllerSettings)}
"""What a sweep's ``[controller]`` table leaves out (its saved form drops defaults)."""


def _sweep_difference(old: Mapping[str, Any], new: Mapping[str, Any]) -> str:
    """How the sweep a dataset holds differs from the one asked for, for the refusal: its
    name, and where the names agree, what else differs (the table and key, the dataset's
    value first: an engine or a controller setting given on the command line)."""
    name = f"sweep {old.get('name')!r}"
    if old.get("name") != new.get("name"):
        return name
    parts = []
    for key in sorted(set(old) | set(new), key=str):
        a, b = old.get(key), new.get(key)
        if a == b:
            continue
        if isinstance(a, Mapping) and isinstance(b, Mapping):
            defaults = _DEFAULT_CONTROLLER if key == "controller" else {}
            for sub in sorted(set(a) | set(b), key=str):
                if a.get(sub) != b.get(sub):
                    was, now = (t.get(sub, defaults.get(sub, "default")) for t in (a, b))
                    parts.append(f"{sub} {was} there, {now} here")
        else:
            parts.append(f"its {key}")
    return f"{name}: {'; '.join(parts)}" if parts else name


def _same_engines(out: Path, recorded: Mapping[str, str], todo: Sequence) -> None:
    """Refuse to add grasps to a dataset begun under another version of an engine they run
    on: the shards would hold two simulators' physics under one name. A complete dataset
    (nothing left to simulate) and an engine the manifest does not record pass."""
    if not todo:
        return
    now = software_versions()
    for engine in sorted({t.controller.engine for t in todo}):
        package = ENGINE_PACKAGES.get(engine)
        was = recorded.get(package) if package else None
        if was is not None and was != now[package]:
            raise UsageError(
                f"{out} was simulated with {package} {was}, this environment has "
                f"{now[package]}: resuming would mix two versions' physics in one dataset; "
                f"generate it again in another --out, or install {package}=={was} to finish it"
            )


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
    from .executors import PARENT_ONLY_FDS

    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise UsageError(f"another generate is writing to {out}; let it finish") from None
        PARENT_ONLY_FDS.add(handle.fileno())  # forked workers close their copy
        try:
            yield
        finally:
            PARENT_ONLY_FDS.discard(handle.fileno())


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
    from ..console import tick

    for done, (index, outcome) in enumerate(results, 1):
        block = index // shard_size
        buffers[block][index] = outcome
        if bar is not None:
            bar.update(1)
        else:  # plain lines where the CLI reports them (a log file, CI): rate, time left
            tick("generate: grasps", done, len(todo))
        if len(buffers[block]) == block_sizes[block]:
            _write_block(out, manifest, block, buffers.pop(block))
    if bar is not None:
        bar.close()


def _write_block(out: Path, manifest: _Manifest, block: int, outcomes: Mapping[int, Any]):
    ok = [(i, o) for i, o in sorted(outcomes.items()) if not isinstance(o, str)]
    failed = [{"task": i, "error": o} for i, o in sorted(outcomes.items()) if isinstance(o, str)]
    name = shard_name(block)
    data = encode_shard([o for _, o in ok])
    fsync_write(out / name, data)
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
