"""Many grasps in memory, over worker processes, and a folder of record files to keep them.

The demo and ``simulate_set`` need a few hundred grasps without a dataset's manifest and
shards; larger runs go through :mod:`~tactile_bullet.datasets.generate`.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..console import plural
from ..errors import UsageError
from ..records import ControllerSettings, GraspRecord, Pose

# --- simulation in bulk -------------------------------------------------------------------------


@dataclass(frozen=True)
class GraspSpec:
    """One grasp to simulate: shape, sizes, pose and seed."""

    shape: str
    params: Mapping[str, float]
    pose: Pose
    seed: int
    controller: ControllerSettings | None = None
    """Controller and engine (None: the defaults, the bullet engine)."""


def _simulate(spec: GraspSpec) -> GraspRecord | str:
    """Worker: a record, or the one-line reason it could not be simulated."""
    from ..objects.shapes import BUILTIN_SHAPES
    from ..sim.grasp import simulate_grasp

    # built-in shapes by value: a worker need not load every plugin to grasp a sphere
    shape = next((s for s in BUILTIN_SHAPES if s.name == spec.shape), spec.shape)
    try:
        return simulate_grasp(shape, spec.params, spec.pose, spec.controller, seed=spec.seed)
    except UsageError as exc:
        return f"{spec.shape} {dict(spec.params)} {spec.pose.offset}: {exc}"


def simulate_many(
    specs: Sequence[GraspSpec], workers: int = 1, show: bool = False, desc: str = "grasps"
) -> tuple[list[GraspRecord], list[str]]:
    """Simulate every spec (in order) over ``workers`` processes: (records, failures)."""
    from ..console import progress

    specs = list(specs)
    workers = max(1, min(int(workers), len(specs) or 1))
    if workers == 1:
        results = [_simulate(s) for s in progress(specs, len(specs), desc, show)]
    else:
        import multiprocessing

        ctx = multiprocessing.get_context("fork" if os.name == "posix" else "spawn")
        with ctx.Pool(workers) as pool:
            stream = pool.imap(_simulate, specs, chunksize=2)
            results = list(progress(stream, len(specs), desc, show))
            # let the workers leave on their own: the pool's exit terminates them, which can
            # hang when its handler thread starts a replacement worker meanwhile (seen once in
            # CI: a worker left waiting on the task queue's lock, joined forever)
            pool.close()
            pool.join()
    records = [r for r in results if isinstance(r, GraspRecord)]
    failures = [r for r in results if not isinstance(r, GraspRecord)]
    return records, failures


_OWN_RECORD = re.compile(r"rec\d{5}\.npz(\.tmp)?")
"""Files :func:`save_records` writes (the .tmp of one interrupted mid-write included)."""


def _own_records(folder: Path) -> list[Path]:
    return sorted(p for p in folder.glob("rec*.npz") if _OWN_RECORD.fullmatch(p.name))


def save_records(
    records: Sequence[GraspRecord], folder: str | os.PathLike, force: bool = False
) -> Path:
    """Write records as ``folder/rec00000.npz``... (each file atomic), a folder that
    :func:`records_from` reads back.

    Records already there are refused unless ``force``; even then nothing is deleted, so a
    folder that would keep records of an earlier, larger run beside the new ones (a mixed
    set) is refused before anything is written."""
    from ..records import save_record

    folder = Path(folder)
    existing = _own_records(folder) if folder.is_dir() else []
    if existing and not force:
        raise UsageError(f"{folder} already holds {plural(len(existing), 'record')}; add "
                         "--force to overwrite them")  # fmt: skip
    names = {f"rec{i:05d}.npz" for i in range(len(records))}
    left = [p.name for p in existing if p.name not in names]
    if left:
        raise UsageError(
            f"{folder} holds {plural(len(existing), 'record')} of an earlier run and this one "
            f"writes {len(records)}: {left[0]}... would be left beside them; choose another folder"
        )
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"cannot create {folder}: {exc.strerror or exc}") from None
    for i, rec in enumerate(records):
        save_record(rec, folder / f"rec{i:05d}.npz")
    return folder


def check_record_folder(folder: Path, planned: int, force: bool) -> None:
    """Refuse, before any work, to write records into a folder holding anything else (the
    demo must never touch a user's files), or holding earlier records unless ``force``, or
    more earlier records than the ``planned`` ones would replace."""
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{folder} exists and is not a directory")
    if not folder.is_dir():
        return
    others = [p.name for p in folder.iterdir() if not _OWN_RECORD.fullmatch(p.name)]
    if others:
        raise UsageError(
            f"{folder} holds files the demo did not write ({others[0]}...): choose another --out"
        )
    existing = _own_records(folder)
    if existing and not force:
        raise UsageError(
            f"{folder} holds {plural(len(existing), 'record')} of an earlier demo; add --force to "
            "overwrite them, or choose another --out"
        )
    if len(existing) > planned:
        raise UsageError(
            f"{folder} holds {plural(len(existing), 'record')} of an earlier, larger demo and "
            f"this one writes {planned}: the rest would be left beside the new ones; choose "
            "another --out"
        )
